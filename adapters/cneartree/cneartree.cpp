// CNearTree (the header-only C++ template <TNear.h>): a near tree after Kalantari and McDonald, pruned by the
// triangle inequality on the distances its element type returns (here sqrt of our squared distance, double).
//
// Two things make it exact besides the margins all square-rooted libraries need (sqrt_libs/exact_sqrt.hpp).
// FindK_NearestNeighbors returns the same point twice and misses a neighbour unless its distance cache is off
// (NTF_NoDistanceCache). It searches in growing annular shells by default; a point that rounding loses at a
// shell's edge would be gone for good, so the single spherical search (NTF_SphericalKNN) is used, where a lost
// point can only lie within rounding of the final radius. Insertions are queued until the first search:
// build() completes them.
#include <TNear.h>

#include "../sqrt_libs/exact_sqrt.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

struct Offset {
  double dx, dy, dz;
  double Norm() const { return std::sqrt(dx * dx + dy * dy + dz * dz); }  // same sum as sq_dist_m2
};

struct NearPoint {
  double xyz[3];
  PointIndex index;
  Offset operator-(const NearPoint& other) const {
    return Offset{xyz[0] - other.xyz[0], xyz[1] - other.xyz[1], xyz[2] - other.xyz[2]};
  }
};

using Tree = CNearTree<NearPoint>;
using TreeNode = Tree::NearTreeNode<NearPoint, double, -1>;

NearPoint probe_at(const double* xyz) { return NearPoint{{xyz[0], xyz[1], xyz[2]}, 0}; }

void exact_sorted(const std::vector<NearPoint>& found, const double* query, std::vector<SqrtCandidate>& rows) {
  rows.clear();
  for (const NearPoint& point : found) rows.emplace_back(sq_dist_m2(query, point.xyz), point.index);
  std::sort(rows.begin(), rows.end());
}

class CNearTreeIndex final : public SearchIndex {
 public:
  explicit CNearTreeIndex(const Params& params) : SearchIndex(describe(params)) {}

  // An estimate (the tree's nodes are private): the object store (a copy of each point with its index) and
  // its collision chain, and about one node per two points (each node holds two objects) plus a pointer to
  // it and a typical allocator header.
  std::size_t index_bytes() const override {
    if (!tree_) return 0;
    constexpr std::size_t kAllocatorHeaderBytes = 16;
    const std::size_t n = model_size();
    return n * (sizeof(NearPoint) + sizeof(std::size_t)) +
           (n / 2 + 1) * (sizeof(TreeNode) + sizeof(TreeNode*) + kAllocatorHeaderBytes);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "cneartree";
    info.library = "CNearTree";
    info.version = "5.1.1";  // Debian's libcneartree-dev: the header states no version
    info.structure = "near tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    info.params = reader.finish();
    info.notes =
        "NTF_NoDistanceCache (with the cache FindK_NearestNeighbors returns duplicates and misses points) and "
        "NTF_SphericalKNN (one pruned search instead of annular shells); sqrt distances: limits widened by "
        "1e-12 of (query to model centre + model diameter), distances recomputed in double and cut at <= r; "
        "k-NN and ranged ask k+1 and, when the k-th and next are within that margin, take FindInSphere of the "
        "k-th distance and cut to k; delayed insertion completed in build(); index_bytes estimated";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_ = std::make_unique<Tree>();
    const long flags = Tree::NTF_NoDistanceCache | Tree::NTF_SphericalKNN;
    tree_->SetFlags(flags, flags);
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      const double* p = model.col(i).data();
      tree_->insert(NearPoint{{p[0], p[1], p[2]}, static_cast<PointIndex>(i)});
    }
    tree_->CompleteDelayedInsert();  // otherwise the first search would build the tree
    margin_.fit(model);
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    search_nearest(queries, static_cast<std::size_t>(k), std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    search_nearest(queries, static_cast<std::size_t>(k), max_dist_m, out);
  }

  void search_nearest(const Cloud& queries, std::size_t k, double max_dist_m, Neighbours& out) const {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries, n_queries * k);
    std::vector<NearPoint> found;
    std::vector<SqrtCandidate> rows;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const auto nearest = [&](std::size_t n, double search_m, std::vector<SqrtCandidate>& sorted) {
        tree_->FindK_NearestNeighbors(n, search_m, found, probe_at(query));
        exact_sorted(found, query, sorted);
      };
      const auto within = [&](double search_m, std::vector<SqrtCandidate>& sorted) {
        tree_->FindInSphere(search_m, found, probe_at(query));
        exact_sorted(found, query, sorted);
      };
      exact_nearest_rows(query, k, max_dist_m, model_size(), margin_, nearest, within, rows);
      append_row(rows, k, max_dist_m * max_dist_m, out);
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    const double limit_sq_m2 = radius_m * radius_m;
    std::vector<NearPoint> found;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      tree_->FindInSphere(margin_.widened_m(radius_m, query), found, probe_at(query));
      for (const NearPoint& point : found) {
        const double sq_m2 = sq_dist_m2(query, point.xyz);
        if (sq_m2 <= limit_sq_m2) out.push(point.index, sq_m2);
      }
      out.end_query();
    }
  }

  // Held by pointer: FindK_NearestNeighbors is not const in the library, though searching changes nothing
  // once every insertion is complete.
  std::unique_ptr<Tree> tree_;
  SqrtMargin margin_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_cneartree(const Params& params) { return std::make_unique<CNearTreeIndex>(params); }

}  // namespace nnb::adapters
