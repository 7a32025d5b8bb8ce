// nanoflann: KDTreeSingleIndexAdaptor over the model in place (no copy), L2 in double.
// nanoflann keeps a point only when its squared distance is strictly below the current bound
// (leaf test `dist < worstDist()`, RadiusResultSet `dist < radius`), so radius and ranged searches
// run with a slightly inflated bound and are then filtered exactly by our inclusive rule.
#include "nanoflann_source.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using nanoflann_source::CloudSource;
using nanoflann_source::append_within;
using nanoflann_source::inflated_sq_bound_m2;

using Metric = nanoflann::L2_Simple_Adaptor<double, CloudSource, double, PointIndex>;
using Tree = nanoflann::KDTreeSingleIndexAdaptor<Metric, CloudSource, 3, PointIndex>;

// nanoflann's documented extension point: a result set. Keeps the k nearest below a fixed bound,
// so the bound prunes the tree from the start (a k-NN search limited by a radius, done natively).
class BoundedKnnResultSet {
 public:
  using DistanceType = double;
  using IndexType = PointIndex;

  BoundedKnnResultSet(std::size_t capacity, double bound_sq_m2, PointIndex* indices, double* sq_dists)
      : capacity_(capacity), bound_sq_m2_(bound_sq_m2), indices_(indices), sq_dists_(sq_dists) {}

  std::size_t size() const { return count_; }
  bool full() const { return count_ == capacity_; }
  double worstDist() const { return count_ < capacity_ ? bound_sq_m2_ : sq_dists_[capacity_ - 1]; }

  // Insertion into a sorted array of at most capacity entries (as nanoflann's KNNResultSet).
  bool addPoint(double sq_dist_m2, PointIndex index) {
    std::size_t i = count_;
    for (; i > 0 && sq_dists_[i - 1] > sq_dist_m2; --i) {
      if (i < capacity_) {
        sq_dists_[i] = sq_dists_[i - 1];
        indices_[i] = indices_[i - 1];
      }
    }
    if (i < capacity_) {
      sq_dists_[i] = sq_dist_m2;
      indices_[i] = index;
      if (count_ < capacity_) ++count_;
    }
    return true;  // keep searching
  }

 private:
  std::size_t capacity_;
  double bound_sq_m2_;
  PointIndex* indices_;
  double* sq_dists_;
  std::size_t count_ = 0;
};

class NanoflannKdTree final : public SearchIndex {
 public:
  explicit NanoflannKdTree(const Params& params) : SearchIndex(describe(params)) {
    leaf_size_ = info().bucket->value;
  }

  // Pool memory of the nodes plus nanoflann's permutation array (its own usedMemory()).
  std::size_t index_bytes() const override { return tree_ ? tree_->usedMemory(*tree_) : 0; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "nanoflann_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "nanoflann";
    info.version = std::to_string((NANOFLANN_VERSION >> 8) & 0xf) + "." +
                   std::to_string((NANOFLANN_VERSION >> 4) & 0xf) + "." + std::to_string(NANOFLANN_VERSION & 0xf);
    info.structure = "k-d tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_bucket("leaf_size", 10, 1, 1 << 20, 1, 64);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "radius and ranged search with a bound inflated past nanoflann's strict '<', then filtered "
        "by sq_dist <= r*r; ranged = findNeighbors with a k-NN result set whose worstDist starts at "
        "max_dist^2 (nanoflann 1.4 has no rknnSearch); version from NANOFLANN_VERSION, which Debian's "
        "1.4.3 header still sets to 0x142";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    source_.cloud = &model;
    tree_ = std::make_unique<Tree>(3, source_, nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size_));
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    nanoflann_source::knn_rows(*tree_, queries, k, model_size(), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    std::vector<std::pair<PointIndex, double>> found;
    const nanoflann::SearchParams unsorted(32, 0.0f, false);
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      tree_->radiusSearch(query, inflated_sq_bound_m2(radius_m, query), found, unsorted);
      for (const auto& [index, sq_dist] : found) out.push(index, sq_dist);
      out.end_query();
    }
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const std::size_t keep = std::min<std::size_t>(static_cast<std::size_t>(k), model_size());
    std::vector<PointIndex> indices(keep);
    std::vector<double> sq_dists(keep);
    const auto n = static_cast<std::size_t>(queries.cols());
    out.reset(n, n);
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      BoundedKnnResultSet result(keep, inflated_sq_bound_m2(max_dist_m, query), indices.data(), sq_dists.data());
      tree_->findNeighbors(result, query, nanoflann::SearchParams());
      append_within(max_dist_m * max_dist_m, indices.data(), sq_dists.data(), result.size(), out);
    }
  }

  int leaf_size_ = 10;
  CloudSource source_;  // the tree holds a reference to it
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_nanoflann_kdtree(const Params& params) {
  return std::make_unique<NanoflannKdTree>(params);
}

}  // namespace nnb::adapters
