// Our compact k-d tree (ours/kdtree.hpp, after libnabo): 8-byte nodes (float cut planes) for both
// scalars, sliding midpoint, buckets copied in tree order, ranged search of the paper's Algorithm 3
// with the first descents of 8 queries interleaved, or each starting from the last for scan-ordered queries.
#include "nnb/registry.hpp"
#include "ours/kdtree.hpp"
#include "ours_rows.hpp"

namespace nnb::adapters {
namespace {

// Measured on every pair in both orders (bench/micro_nns, ours/README.md): 64 beats 48 and 80, as
// scan-ordered queries reuse the last descent; far larger buckets than libnabo's 5 pay off here.
constexpr int kDefaultBucketSize = 64;

class OursKdTree final : public ours_rows::OursIndex<ours::KdTree> {
 public:
  explicit OursKdTree(const Params& params)
      : OursIndex(describe(params)), bucket_size_(info().bucket->value) {}

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "ours_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "ours (this project, after libnabo)";
    info.version = "1";
    info.structure = "k-d tree";
    ParamReader reader(info.name, params);
    reader.get_bucket("bucket_size", kDefaultBucketSize, 1, 1 << 20, 4, 128);
    info = shared_info(std::move(info), reader);
    info.builds_on_threads = true;
    return info;
  }

  void do_build(const Cloud& model) override {
    build_tree(model, [&](auto& tree, const double* xyz, std::size_t n) { tree.build(xyz, n, bucket_size_, threads()); });
  }

  int bucket_size_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_ours_kdtree(const Params& params) { return std::make_unique<OursKdTree>(params); }

}  // namespace nnb::adapters
