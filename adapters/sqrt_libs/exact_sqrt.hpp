#pragma once
// What the libraries that prune by the triangle inequality on square-rooted distances (CNearTree, GeographicLib's
// vantage-point tree) share to come out exact. Rounding can move a pruning test by a few ulps of the distances
// it adds, so every limit handed to the library is widened by a margin; it is asked for k+1 neighbours, and when
// the k-th and the (k+1)-th lie within that margin of each other, every point within the k-th distance is
// fetched, so that ties resolve as brute force resolves them; distances are recomputed in double and cut at
// <= r. Rows end up as brute force gives them: the k nearest by (sq_dist, index).
#include "nnb/cloud.hpp"
#include "nnb/neighbours.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

namespace nnb::adapters {

/// A neighbour as brute force orders them: (squared distance in m^2, model index).
using SqrtCandidate = std::pair<double, PointIndex>;

/// How far rounding may move a pruning test about one model: each adds or subtracts distances no longer than
/// (query to model centre + model diameter), rounded to 1e-16 of that; 1e-12 of it leaves a wide margin.
class SqrtMargin {
 public:
  void fit(const Cloud& model) {
    const Eigen::Vector3d lo = model.rowwise().minCoeff();
    const Eigen::Vector3d hi = model.rowwise().maxCoeff();
    centre_ = 0.5 * (lo + hi);
    diameter_m_ = (hi - lo).norm();
  }

  double margin_m(const double* query) const {
    const double to_centre_m = (Eigen::Map<const Eigen::Vector3d>(query) - centre_).norm();
    return kPad * (to_centre_m + diameter_m_) + std::numeric_limits<double>::min();
  }

  /// limit_m widened so that no point within it is pruned by rounding (an infinite limit stays infinite).
  double widened_m(double limit_m, const double* query) const {
    return std::isinf(limit_m) ? limit_m : limit_m * (1.0 + kPad) + margin_m(query);
  }

 private:
  static constexpr double kPad = 1e-12;
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  double diameter_m_ = 0.0;
};

/// At least the k nearest within max_dist_m of query in rows, sorted by (sq_dist, index), ties at the k-th
/// complete. nearest(n, search_m, rows) fills rows, sorted, with the library's n nearest within search_m;
/// within(search_m, rows) with every point within search_m.
template <class Nearest, class Within>
void exact_nearest_rows(const double* query, std::size_t k, double max_dist_m, std::size_t model_size,
                        const SqrtMargin& margin, Nearest&& nearest, Within&& within, std::vector<SqrtCandidate>& rows) {
  const double margin_m = margin.margin_m(query);
  nearest(std::min(k + 1, model_size), margin.widened_m(max_dist_m, query), rows);
  // The search lost nothing nearer than its last bound (the (k+1)-th) minus the margin: unless the k-th lies
  // that close to the (k+1)-th, the k nearest are right.
  if (rows.size() <= k || std::sqrt(rows[k - 1].first) + margin_m < std::sqrt(rows[k].first)) return;
  const double limit_sq_m2 = std::min(rows[k - 1].first, max_dist_m * max_dist_m);
  within(margin.widened_m(std::sqrt(limit_sq_m2), query), rows);
  rows.erase(std::find_if(rows.begin(), rows.end(), [&](const SqrtCandidate& c) { return c.first > limit_sq_m2; }),
             rows.end());
}

/// Appends one query's row: at most k of rows, those within limit_sq_m2.
inline void append_row(const std::vector<SqrtCandidate>& rows, std::size_t k, double limit_sq_m2, Neighbours& out) {
  std::size_t written = 0;
  for (const auto& [sq_m2, index] : rows) {
    if (written == k || sq_m2 > limit_sq_m2) break;
    out.push(index, sq_m2);
    ++written;
  }
  out.end_query();
}

}  // namespace nnb::adapters
