#pragma once
// The k best candidates of one query, for adapters that search in double themselves: a max-heap with the
// squared radius beyond which nothing can enter (the limit until k are found, then the k-th).
#include "nnb/cloud.hpp"
#include "nnb/neighbours.hpp"

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace nnb {

class BestK {
 public:
  /// (squared distance m^2, index): equal distances go to the lower index, as brute force orders them.
  using Candidate = std::pair<double, PointIndex>;

  BestK(std::size_t k, double limit_sq_m2) : k_(k), limit_sq_m2_(limit_sq_m2) { heap_.reserve(k); }
  double bound_sq_m2() const { return heap_.size() < k_ ? limit_sq_m2_ : heap_.front().first; }
  void offer(double sq_m2, PointIndex index) {
    if (sq_m2 > limit_sq_m2_) return;
    const Candidate c{sq_m2, index};
    if (heap_.size() < k_) {
      heap_.push_back(c);
      std::push_heap(heap_.begin(), heap_.end());
    } else if (c < heap_.front()) {
      std::pop_heap(heap_.begin(), heap_.end());
      heap_.back() = c;
      std::push_heap(heap_.begin(), heap_.end());
    }
  }
  /// Appends the candidates, nearest first, as the next query's row of out.
  void write_sorted(Neighbours& out) {
    std::sort_heap(heap_.begin(), heap_.end());
    for (const auto& [sq, index] : heap_) out.push(index, sq);
    out.end_query();
  }

 private:
  std::size_t k_;
  double limit_sq_m2_;
  std::vector<Candidate> heap_;
};

}  // namespace nnb
