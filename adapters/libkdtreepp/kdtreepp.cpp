// libkdtree++'s k-d tree (KDTree::KDTree<3, ...>, one point per node, built balanced from the whole model).
//
// The library answers 1-NN (find_nearest) and L-infinity cubes (find_within_range), both in double, but
// compares square-rooted distances: sqrt(d2) <= max can hold while d2 > max^2. It has no k-NN. Its
// find_nearest_if(point, max, predicate) asks the predicate about every node before measuring it, and only a
// node the predicate accepts can lower the bound that prunes the search. So k-NN and ranged search run the
// library's own nearest search with a predicate that measures each node exactly in double, keeps the k best
// and accepts a node only when it has just become the k-th: the library's bound is then sqrt of the current
// k-th squared distance, and every point as near as it (ties included) is still visited. Radius search is the
// cube, padded, then cut at d2 <= r^2.
#include <kdtree++/kdtree.hpp>

#include "nnb/next_float.hpp"
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

// Relative margin of the cube and of the ranged bound: far above the rounding of q +- r and of sqrt.
constexpr double kPad = 1e-12;

using Candidate = std::pair<double, PointIndex>;  // (squared distance, index): brute force's order

struct TreePoint {
  typedef double value_type;  // read by the library's accessor
  double xyz[3];
  PointIndex index;
  double operator[](std::size_t d) const { return xyz[d]; }
};

using Tree = KDTree::KDTree<3, TreePoint>;

std::string libkdtree_version() {
  return std::to_string(KDTREE_VERSION / 100000) + "." + std::to_string(KDTREE_VERSION / 100 % 1000) + "." +
         std::to_string(KDTREE_VERSION % 100);
}

TreePoint query_point(const double* xyz) { return TreePoint{{xyz[0], xyz[1], xyz[2]}, 0}; }

// The k best so far as a max-heap on (sq_dist, index), for one query.
struct NearestQuery {
  const double* query;
  std::size_t k;
  double limit_sq_m2;
  std::vector<Candidate> heap;
};

// find_nearest_if's predicate (copied by value inside the library, hence the pointer): records the node and
// returns true only when it is now the k-th best, so that the library lowers its bound to it.
class KeepNearest {
 public:
  explicit KeepNearest(NearestQuery& state) : state_(&state) {}

  bool operator()(const TreePoint& point) const {
    NearestQuery& s = *state_;
    const double sq_m2 = sq_dist_m2(s.query, point.xyz);
    if (sq_m2 > s.limit_sq_m2) return false;
    const Candidate candidate{sq_m2, point.index};
    if (s.heap.size() < s.k) {
      s.heap.push_back(candidate);
      std::push_heap(s.heap.begin(), s.heap.end());
    } else if (candidate < s.heap.front()) {
      std::pop_heap(s.heap.begin(), s.heap.end());
      s.heap.back() = candidate;
      std::push_heap(s.heap.begin(), s.heap.end());
    } else {
      return false;
    }
    return s.heap.size() == s.k && s.heap.front() == candidate;
  }

 private:
  NearestQuery* state_;
};

// visit_within_range's visitor (also copied by value): the exact filter of the cube's points.
class KeepWithin {
 public:
  KeepWithin(const double* query, double limit_sq_m2, Neighbours& out)
      : query_(query), limit_sq_m2_(limit_sq_m2), out_(&out) {}

  void operator()(const TreePoint& point) const {
    const double sq_m2 = sq_dist_m2(query_, point.xyz);
    if (sq_m2 <= limit_sq_m2_) out_->push(point.index, sq_m2);
  }

 private:
  const double* query_;
  double limit_sq_m2_;
  Neighbours* out_;
};

class LibKdTreePP final : public SearchIndex {
 public:
  explicit LibKdTreePP(const Params& params) : SearchIndex(describe(params)) {}

  // One heap node per point (three links and the point with its index) plus a typical allocator header.
  std::size_t index_bytes() const override {
    constexpr std::size_t kAllocatorHeaderBytes = 16;
    return tree_ ? tree_->size() * (sizeof(KDTree::_Node<TreePoint>) + kAllocatorHeaderBytes) : 0;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "kdtreepp";
    info.concurrency = Concurrency::queries;
    info.library = "libkdtree++";
    info.version = libkdtree_version();
    info.structure = "k-d tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::via_box;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    info.params = reader.finish();
    info.notes =
        "no k-NN and sqrt-based bounds (sqrt(d2) <= max): k-NN and ranged run find_nearest_if with a predicate "
        "that measures each node in double, keeps the k best by (d2, index) and accepts a node only when it "
        "becomes the k-th, so the library prunes by the k-th distance; ranged starts from max_dist padded 1e-12 "
        "and cuts at d2 <= max_dist^2; radius = find_within_range's L-infinity cube padded 1e-12 relative + 1 "
        "ulp, then d2 <= r^2; one point per node, no bucket";
    return info;
  }

  void do_build(const Cloud& model) override {
    std::vector<TreePoint> points(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      const double* p = model.col(i).data();
      points[static_cast<std::size_t>(i)] = TreePoint{{p[0], p[1], p[2]}, static_cast<PointIndex>(i)};
    }
    tree_ = std::make_unique<Tree>(points.begin(), points.end());  // balanced: median splits
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
    NearestQuery state{nullptr, k, max_dist_m * max_dist_m, {}};
    state.heap.reserve(k);
    const double start_bound_m = next_up(max_dist_m * (1.0 + kPad));
    for (std::size_t q = 0; q < n_queries; ++q) {
      state.query = queries.col(static_cast<Eigen::Index>(q)).data();
      state.heap.clear();
      tree_->find_nearest_if(query_point(state.query), start_bound_m, KeepNearest(state));
      std::sort_heap(state.heap.begin(), state.heap.end());
      for (const auto& [sq_m2, index] : state.heap) out.push(index, sq_m2);
      out.end_query();
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    const double half_width_m = radius_m * (1.0 + kPad);
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      Tree::_Region_ cube;
      for (int d = 0; d < 3; ++d) {
        cube._M_low_bounds[d] = next_down(query[d] - half_width_m);
        cube._M_high_bounds[d] = next_up(query[d] + half_width_m);
      }
      tree_->visit_within_range(cube, KeepWithin(query, radius_m * radius_m, out));
      out.end_query();
    }
  }

  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_kdtreepp(const Params& params) {
  return std::make_unique<LibKdTreePP>(params);
}

}  // namespace nnb::adapters
