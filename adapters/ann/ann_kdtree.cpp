// ANN: ANNkd_tree with the sliding-midpoint rule, exact search (eps = 0), points referenced in place.
// ANN keeps its search state in globals: single-threaded only. annClose() frees static data shared by
// every tree, so it is never called here (the process exit frees it).
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <ANN/ANN.h>
#include <ANN/ANNperf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

// Node sizes of ANN 1.1.2 on a 64-bit ABI (kd_tree.h is not installed): a leaf holds a vtable pointer,
// a point count and a bucket pointer; a split node a vtable pointer, the cut dimension, the cut value,
// the two bounds and two child pointers.
constexpr std::size_t kAnnLeafBytes = 8 + 8 + 8;
constexpr std::size_t kAnnSplitBytes = 8 + 8 + 8 + 2 * 8 + 2 * 8;

// Squared search radius (m^2) wide enough that ANN's rounding can lose no point we count; the exact
// filter afterwards applies our inclusive rule.
double inflated_sq_bound_m2(double limit_m, const double* query) {
  const double scale = std::max({std::abs(query[0]), std::abs(query[1]), std::abs(query[2]), limit_m});
  const double padded_m = limit_m + 1e-12 * scale;
  return next_up(padded_m * padded_m);
}

class AnnKdTree final : public SearchIndex {
 public:
  explicit AnnKdTree(const Params& params) : SearchIndex(describe(params)) {
    bucket_size_ = info().bucket->value;
  }

  std::size_t index_bytes() const override {
    if (!tree_) return 0;
    const std::size_t trivial_leaves = static_cast<std::size_t>(stats_.n_tl);  // one shared static node
    return static_cast<std::size_t>(stats_.n_lf) * kAnnLeafBytes - trivial_leaves * kAnnLeafBytes +
           static_cast<std::size_t>(stats_.n_spl) * kAnnSplitBytes +
           points_.size() * (sizeof(ANNpoint) + sizeof(ANNidx)) + 2 * 3 * sizeof(ANNcoord);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "ann_kdtree";
    info.library = "ANN";
    info.version = ANNversion;
    info.structure = "k-d tree (sliding midpoint)";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native_unpruned;
    ParamReader reader(info.name, params);
    reader.get_bucket("bucket_size", 1, 1, 1 << 20, 1, 64);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "k clamped to the model size (ANN aborts the process otherwise); radius = annkFRSearch twice "
        "(k=0 for the count, then k=count), with a slightly inflated squared radius and an exact "
        "sq_dist <= r*r filter; ranged = annkFRSearch with k, which keeps the k nearest but visits the whole "
        "ball (it also counts every point within it), hence unpruned; annClose() never called";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    points_.resize(static_cast<std::size_t>(model.cols()));
    // ANN only reads the points: reference the model's columns instead of copying them.
    for (Eigen::Index i = 0; i < model.cols(); ++i) points_[static_cast<std::size_t>(i)] = const_cast<double*>(model.col(i).data());
    tree_ = std::make_unique<ANNkd_tree>(points_.data(), static_cast<int>(model.cols()), 3, bucket_size_,
                                         ANN_KD_SL_MIDPT);
    stats_.reset();
    tree_->getStats(stats_);
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const int keep = std::min(k, static_cast<int>(model_size()));
    std::vector<ANNidx> indices(static_cast<std::size_t>(keep));
    std::vector<ANNdist> sq_dists(static_cast<std::size_t>(keep));
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(keep) * queries.cols());
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      tree_->annkSearch(const_cast<double*>(queries.col(q).data()), keep, indices.data(), sq_dists.data(), 0.0);
      for (int i = 0; i < keep; ++i) {
        if (indices[i] != ANN_NULL_IDX) out.push(static_cast<PointIndex>(indices[i]), sq_dists[i]);
      }
      out.end_query();
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    std::vector<ANNidx> indices;
    std::vector<ANNdist> sq_dists;
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      double* query = const_cast<double*>(queries.col(q).data());
      const double bound_sq_m2 = inflated_sq_bound_m2(radius_m, query);
      const int count = tree_->annkFRSearch(query, bound_sq_m2, 0, nullptr, nullptr, 0.0);
      indices.assign(static_cast<std::size_t>(count), ANN_NULL_IDX);
      sq_dists.resize(static_cast<std::size_t>(count));
      if (count > 0) tree_->annkFRSearch(query, bound_sq_m2, count, indices.data(), sq_dists.data(), 0.0);
      for (int i = 0; i < count; ++i) {
        if (indices[i] != ANN_NULL_IDX) out.push(static_cast<PointIndex>(indices[i]), sq_dists[i]);
      }
      out.end_query();
    }
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const int keep = std::min(k, static_cast<int>(model_size()));
    std::vector<ANNidx> indices(static_cast<std::size_t>(keep));
    std::vector<ANNdist> sq_dists(static_cast<std::size_t>(keep));
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(keep) * queries.cols());
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      double* query = const_cast<double*>(queries.col(q).data());
      std::fill(indices.begin(), indices.end(), ANN_NULL_IDX);
      tree_->annkFRSearch(query, inflated_sq_bound_m2(max_dist_m, query), keep, indices.data(), sq_dists.data(), 0.0);
      for (int i = 0; i < keep; ++i) {
        if (indices[i] != ANN_NULL_IDX) out.push(static_cast<PointIndex>(indices[i]), sq_dists[i]);
      }
      out.end_query();
    }
    filter_by_sq_dist(max_dist_m * max_dist_m, out);
  }

  int bucket_size_ = 1;
  std::vector<ANNpoint> points_;  // pointers into the model's columns
  std::unique_ptr<ANNkd_tree> tree_;
  ANNkdStats stats_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_ann_kdtree(const Params& params) { return std::make_unique<AnnKdTree>(params); }

}  // namespace nnb::adapters
