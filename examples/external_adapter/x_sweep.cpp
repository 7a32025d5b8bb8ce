// An example adapter written outside the tree: the model sorted by x; each query walks outwards from its
// own x, nearer x first, until the x distance alone rules out every point left. Exact, in double, with
// the project's boundary rule: a point counts when sq_dist_m2(query, point) <= limit (inclusive).
//
// Why the walk may stop: the x term is rounded exactly as inside sq_dist_m2 (same subtraction, same
// product), and adding the other two non-negative terms can only keep or raise it, so a point whose
// rounded x term exceeds the bound has a squared distance beyond it too; the x term only grows outwards.
#include "nnb/registry.hpp"

#include <algorithm>
#include <cstddef>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using Candidate = std::pair<double, PointIndex>;  // (squared distance m^2, index): ties go to the lower index

class XSweep final : public SearchIndex {
 public:
  explicit XSweep(const Params& params) : SearchIndex(describe(params)) {}

  std::size_t index_bytes() const override {
    return order_.capacity() * sizeof(PointIndex) + xs_.capacity() * sizeof(double);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "x_sweep";
    info.library = "x sweep (external example)";
    info.version = "1";
    info.structure = "points sorted by x";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    info.params = ParamReader(info.name, params).finish();
    return info;
  }

  void do_build(const Cloud& model) override {
    model_ = &model;
    order_.resize(static_cast<std::size_t>(model.cols()));
    std::iota(order_.begin(), order_.end(), PointIndex{0});
    std::stable_sort(order_.begin(), order_.end(),
                     [&](PointIndex a, PointIndex b) { return model(0, a) < model(0, b); });
    xs_.resize(order_.size());
    for (std::size_t i = 0; i < order_.size(); ++i) xs_[i] = model(0, order_[i]);
  }

  // Calls visit(index, sq_dist) for model points in order of growing x distance while their x term
  // is <= bound(); visit may lower the bound.
  template <class Bound, class Visit>
  void sweep(const double* query, Bound bound, Visit visit) const {
    const auto x_term = [&](std::size_t i) {
      const double dx = query[0] - xs_[i];
      return dx * dx;
    };
    std::size_t right = static_cast<std::size_t>(std::lower_bound(xs_.begin(), xs_.end(), query[0]) - xs_.begin());
    std::size_t left = right;  // the next points are left - 1 and right
    while (left > 0 || right < xs_.size()) {
      const double inf = std::numeric_limits<double>::infinity();
      const double l = left > 0 ? x_term(left - 1) : inf;
      const double r = right < xs_.size() ? x_term(right) : inf;
      if (std::min(l, r) > bound()) return;
      const PointIndex i = l <= r ? order_[--left] : order_[right++];
      visit(i, sq_dist_m2(query, model_->col(i).data()));
    }
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    k_nearest_within(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    k_nearest_within(queries, k, max_dist_m * max_dist_m, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const double limit_sq = radius_m * radius_m;
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      sweep(queries.col(q).data(), [&] { return limit_sq; }, [&](PointIndex i, double sq) {
        if (sq <= limit_sq) out.push(i, sq);
      });
      out.end_query();
    }
  }

  // A max-heap of the best k so far; the bound is the limit until k are found, then the k-th best
  // (inclusive, so that a tie with a lower index is still seen).
  void k_nearest_within(const Cloud& queries, int k, double limit_sq_m2, Neighbours& out) const {
    const auto keep = static_cast<std::size_t>(k);
    out.reset(static_cast<std::size_t>(queries.cols()));
    std::vector<Candidate> heap;
    heap.reserve(keep + 1);
    const auto bound = [&] { return heap.size() < keep ? limit_sq_m2 : heap.front().first; };
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      heap.clear();
      sweep(queries.col(q).data(), bound, [&](PointIndex i, double sq) {
        const Candidate c{sq, i};
        if (sq > limit_sq_m2) return;
        if (heap.size() < keep) {
          heap.push_back(c);
          std::push_heap(heap.begin(), heap.end());
        } else if (c < heap.front()) {
          std::pop_heap(heap.begin(), heap.end());
          heap.back() = c;
          std::push_heap(heap.begin(), heap.end());
        }
      });
      std::sort_heap(heap.begin(), heap.end());
      for (const auto& [sq, index] : heap) out.push(index, sq);
      out.end_query();
    }
  }

  const Cloud* model_ = nullptr;
  std::vector<PointIndex> order_;  // model indices sorted by x (stable: equal x keep index order)
  std::vector<double> xs_;         // their x, in that order
};

}  // namespace

std::unique_ptr<SearchIndex> make_x_sweep(const Params& params) { return std::make_unique<XSweep>(params); }

}  // namespace nnb::adapters
