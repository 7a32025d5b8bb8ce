// Our compact k-d tree (ours/kdtree.hpp, after libnabo): 8-byte nodes (float cut planes) for both
// scalars, sliding midpoint, buckets copied in tree order, ranged search of the paper's Algorithm 3
// with the first descents of 8 queries interleaved.
#include "nnb/registry.hpp"
#include "ours/kdtree.hpp"
#include "ours_rows.hpp"

#include <limits>

namespace nnb::adapters {
namespace {

// Measured best on the Figure 3 and SICK pairs (bench/micro_nns; 24..48 within noise): larger buckets
// than libnabo's 5 pay off here.
constexpr int kDefaultBucketSize = 32;

class OursKdTree final : public SearchIndex {
 public:
  explicit OursKdTree(const Params& params) : SearchIndex(describe(params)) {
    bucket_size_ = std::stoi(info().params.at("bucket_size"));
    use_float_ = info().params.at("scalar") == "float";
  }

  std::size_t index_bytes() const override {
    return use_float_ ? float_.node_bytes() + float_.index_bytes() + float_.point_copy_bytes()
                      : double_.node_bytes() + double_.index_bytes() + double_.point_copy_bytes();
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "ours_kdtree";
    info.library = "ours (this project, after libnabo)";
    info.version = "1";
    info.structure = "k-d tree";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_int("bucket_size", kDefaultBucketSize, 1, 1 << 20);
    info.scalar = reader.get_choice("scalar", "double", {"float", "double"});
    info.params = reader.finish();
    info.notes = info.scalar == "float" ? "float search widened by its rounding bound, refined in double"
                                        : "distances computed as sq_dist_m2, bit-exact";
    return info;
  }

  void do_build(const Cloud& model) override {
    model_ = &model;
    const auto n = static_cast<std::size_t>(model.cols());
    if (use_float_) float_.build(model.data(), n, bucket_size_);
    else double_.build(model.data(), n, bucket_size_);
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    do_ranged(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const double limit_sq_m2 = max_dist_m * max_dist_m;
    if (use_float_) ours_rows::ranged<float>(float_, *model_, queries, k, limit_sq_m2, out);
    else ours_rows::ranged<double>(double_, *model_, queries, k, limit_sq_m2, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    if (use_float_) ours_rows::radius<float>(float_, *model_, queries, radius_m, out);
    else ours_rows::radius<double>(double_, *model_, queries, radius_m, out);
  }

  const Cloud* model_ = nullptr;
  int bucket_size_ = kDefaultBucketSize;
  bool use_float_ = false;
  ours::KdTree<float> float_;
  ours::KdTree<double> double_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_ours_kdtree(const Params& params) { return std::make_unique<OursKdTree>(params); }

}  // namespace nnb::adapters
