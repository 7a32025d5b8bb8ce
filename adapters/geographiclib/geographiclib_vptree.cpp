// GeographicLib's NearestNeighbor (the header-only class template <GeographicLib/NearestNeighbor.hpp>): a
// vantage-point tree over any metric, pruned by the triangle inequality on the distances its functor returns
// (here sqrt of our squared distance, double). Its one search call is a ranged search: the k nearest within
// maxdist, inclusive, nearest first; with k the number of points it is a radius search.
//
// Its distances are square roots: made exact as CNearTree is (sqrt_libs/exact_sqrt.hpp). The tree does not
// keep the points: Search takes them again.
#include <GeographicLib/Config.h>
#include <GeographicLib/NearestNeighbor.hpp>

#include "../sqrt_libs/exact_sqrt.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

struct VpPoint {
  double xyz[3];
};

struct EuclideanDistance {
  double operator()(const VpPoint& a, const VpPoint& b) const { return std::sqrt(sq_dist_m2(a.xyz, b.xyz)); }
};

using Tree = GeographicLib::NearestNeighbor<double, VpPoint, EuclideanDistance>;

// The tree's nodes are private; their layout for a double tree: a union of two lower and two upper bounds
// and two child indices (40 bytes) with a leaf's point indices (at most 10 ints), then the node's own index.
constexpr std::size_t kNodeBytes = 48;

// Nodes the library's init() makes for n points: a node holding a vantage point above a child of the
// ((n + 1) / 2 - 1) nearest and one of the rest, down to leaves of at most max(1, bucket) points.
std::size_t node_count(std::size_t n, int bucket, std::map<std::size_t, std::size_t>& memo) {
  if (n == 0) return 0;
  if (n <= static_cast<std::size_t>(std::max(1, bucket))) return 1;
  if (const auto it = memo.find(n); it != memo.end()) return it->second;
  const std::size_t near = (n + 1) / 2 - 1;
  const std::size_t count = 1 + node_count(near, bucket, memo) + node_count(n - 1 - near, bucket, memo);
  memo.emplace(n, count);
  return count;
}

// The capacity a vector reaches when filled by push_back from empty, as libstdc++ doubles it.
std::size_t doubled_capacity(std::size_t count) {
  std::size_t capacity = count == 0 ? 0 : 1;
  while (capacity < count) capacity *= 2;
  return capacity;
}

class VpTreeIndex final : public SearchIndex {
 public:
  explicit VpTreeIndex(const Params& params) : SearchIndex(describe(params)) {}

  // The copy of the points Search reads, and the nodes in the vector the library fills by push_back.
  std::size_t index_bytes() const override {
    if (points_.empty()) return 0;
    std::map<std::size_t, std::size_t> memo;
    return points_.capacity() * sizeof(VpPoint) + doubled_capacity(node_count(points_.size(), bucket_, memo)) * kNodeBytes;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "geographiclib_vptree";
    info.library = "GeographicLib";
    info.version = GEOGRAPHICLIB_VERSION_STRING;
    info.structure = "vantage-point tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    // The library accepts 0 to 2 + 4 * sizeof(double) / sizeof(int) = 10 points a leaf (0: one a node).
    reader.get_bucket("bucket", 4, 0, 10, 1, 10);
    info.bucket = reader.bucket();
    info.params = reader.finish();
    info.notes =
        "sqrt distances: limits widened by 1e-12 of (query to model centre + model diameter), distances "
        "recomputed in double and cut at <= r; k-NN and ranged ask k+1 and, when the k-th and next are within "
        "that margin, take every point within the k-th distance and cut to k; radius search is Search with k = "
        "the number of points; one thread (Search updates the tree's statistics counters); index_bytes counts "
        "the nodes the library builds";
    return info;
  }

  void do_build(const Cloud& model) override {
    if (model.cols() > INT_MAX) throw InputError("geographiclib_vptree: more points than an int counts");
    points_.resize(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      const double* p = model.col(i).data();
      points_[static_cast<std::size_t>(i)] = VpPoint{{p[0], p[1], p[2]}};
    }
    bucket_ = info().bucket->value;
    tree_.Initialize(points_, EuclideanDistance{}, bucket_);
    margin_.fit(model);
  }

  // Every point the library finds among the k nearest within search_m, as (squared distance, index),
  // sorted as brute force sorts them.
  void search_sorted(const double* query, std::size_t k, double search_m, std::vector<SqrtCandidate>& rows) const {
    const VpPoint probe{{query[0], query[1], query[2]}};
    const double limit_m = std::isinf(search_m) ? std::numeric_limits<double>::max() : search_m;
    tree_.Search(points_, EuclideanDistance{}, probe, found_, static_cast<int>(k), limit_m);
    rows.clear();
    for (const int index : found_) {
      rows.emplace_back(sq_dist_m2(query, points_[static_cast<std::size_t>(index)].xyz), static_cast<PointIndex>(index));
    }
    std::sort(rows.begin(), rows.end());
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
    std::vector<SqrtCandidate> rows;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const auto nearest = [&](std::size_t n, double search_m, std::vector<SqrtCandidate>& found) {
        search_sorted(query, n, search_m, found);
      };
      const auto within = [&](double search_m, std::vector<SqrtCandidate>& found) {
        search_sorted(query, points_.size(), search_m, found);
      };
      exact_nearest_rows(query, k, max_dist_m, points_.size(), margin_, nearest, within, rows);
      append_row(rows, k, max_dist_m * max_dist_m, out);
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    const double limit_sq_m2 = radius_m * radius_m;
    std::vector<SqrtCandidate> rows;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      search_sorted(query, points_.size(), margin_.widened_m(radius_m, query), rows);
      append_row(rows, points_.size(), limit_sq_m2, out);
    }
  }

  std::vector<VpPoint> points_;
  Tree tree_;
  int bucket_ = 4;
  SqrtMargin margin_;
  mutable std::vector<int> found_;  // Search's answer, reused: the adapter runs on one thread
};

}  // namespace

std::unique_ptr<SearchIndex> make_geographiclib_vptree(const Params& params) {
  return std::make_unique<VpTreeIndex>(params);
}

}  // namespace nnb::adapters
