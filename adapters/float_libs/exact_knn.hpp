#pragma once
// Exact k-NN and ranged search on top of a float library's own. Recomputing the library's k nearest in double is not
// enough: when two points compete for the k-th place within float rounding (~1e-7 of the cloud's
// extent) the library may return the wrong one, and the right one is then missing. So the library is
// asked for k+1: if its (k+1)-th candidate is, even allowing for float error, farther than the k-th
// nearest in double, nothing it left out can compete; otherwise (a near-tie or an exact tie at the
// boundary, rare) a float radius search around the k-th double distance collects every contender.
// Rows end up as brute force gives them: the k nearest by (sq_dist, index), ties to the lowest index.
#include "float_frame.hpp"
#include "nnb/neighbours.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {

/// Number of neighbours to ask a float library for: k+1 when the model has more than k points, else all.
inline std::size_t float_knn_candidates(std::size_t k, std::size_t model_size) {
  return k < model_size ? k + 1 : model_size;
}

/// What a float library returned for one query: model indices and its own float squared distances (m^2).
struct FloatCandidates {
  std::vector<PointIndex> indices;
  std::vector<float> sq_dists_m2;
};

/// Fills out with the exact k nearest within max_dist_m of each query, from a float library's own ranged
/// search: ranged_search(q, n, search_m, candidates) must fill at most n of the library's nearest points
/// closer than search_m in float (any order). It is asked for k+1 within a radius widened for float error.
/// Fewer than k+1 back means every point that can count is among them. k+1 back means the library may
/// have left out points as far as its farthest candidate: when that one is within float error of the k-th
/// nearest in double (or of max_dist_m, when fewer than k lie within it), a radius search collects every
/// contender, as in exact_knn. Returns the number of queries that needed the radius search.
template <class RangedSearch, class RadiusSearch>
std::size_t exact_ranged(const Cloud& model, const Cloud& queries, std::size_t k, double max_dist_m,
                         const FloatFrame& frame, RangedSearch&& ranged_search, RadiusSearch&& radius_search,
                         Neighbours& out) {
  const auto model_size = static_cast<std::size_t>(model.cols());
  const std::size_t kk = std::min(k, model_size);
  const std::size_t asked = float_knn_candidates(kk, model_size);
  const double limit_sq_m2 = max_dist_m * max_dist_m;
  const auto n_queries = static_cast<std::size_t>(queries.cols());
  out.reset(n_queries, std::isinf(max_dist_m) ? n_queries * kk : 0);  // k-NN fills every row
  FloatCandidates candidates;
  std::vector<PointIndex> contenders;
  std::vector<std::pair<double, PointIndex>> row;
  std::size_t fallbacks = 0;
  const auto fill_row = [&](const double* query, const std::vector<PointIndex>& indices) {
    row.clear();
    for (const PointIndex index : indices) row.emplace_back(sq_dist_m2(query, model.col(index).data()), index);
    std::sort(row.begin(), row.end());
  };
  for (std::size_t q = 0; q < n_queries; ++q) {
    const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
    ranged_search(q, asked, frame.search_radius_m(query, max_dist_m), candidates);
    if (candidates.indices.size() > asked) {
      throw std::logic_error("float ranged search returned " + std::to_string(candidates.indices.size()) +
                             " neighbours, more than the " + std::to_string(asked) + " asked");
    }
    fill_row(query, candidates.indices);
    if (candidates.indices.size() == asked && asked > kk) {
      const float farthest_sq_m2 = *std::max_element(candidates.sq_dists_m2.begin(), candidates.sq_dists_m2.end());
      const auto within = static_cast<std::size_t>(
          std::upper_bound(row.begin(), row.end(), std::make_pair(limit_sq_m2, PointIndex(-1))) - row.begin());
      const double bound_m = within >= kk ? std::sqrt(row[kk - 1].first) : max_dist_m;
      if (!frame.surely_beyond(query, std::sqrt(static_cast<double>(farthest_sq_m2)), bound_m)) {
        ++fallbacks;
        radius_search(q, frame.search_radius_m(query, bound_m), contenders);
        fill_row(query, contenders);
      }
    }
    for (std::size_t i = 0; i < std::min(kk, row.size()) && row[i].first <= limit_sq_m2; ++i) {
      out.push(row[i].second, row[i].first);
    }
    out.end_query();
  }
  return fallbacks;
}

/// Fills out with the exact k nearest of each query (nearest first, ties to the lowest index): exact_ranged
/// without a limit. knn_search(q, n, candidates) must fill the library's n nearest of query column q (any
/// order); radius_search(q, radius_m, indices) every point whose float distance is below radius_m (metres).
template <class KnnSearch, class RadiusSearch>
std::size_t exact_knn(const Cloud& model, const Cloud& queries, std::size_t k, const FloatFrame& frame,
                      KnnSearch&& knn_search, RadiusSearch&& radius_search, Neighbours& out) {
  const auto knn_as_ranged = [&](std::size_t q, std::size_t n, double, FloatCandidates& candidates) {
    knn_search(q, n, candidates);
    if (candidates.indices.size() != n) {
      throw std::logic_error("float k-NN returned " + std::to_string(candidates.indices.size()) + " of " +
                             std::to_string(n) + " neighbours");
    }
  };
  return exact_ranged(model, queries, k, std::numeric_limits<double>::infinity(), frame, knn_as_ranged,
                      radius_search, out);
}

}  // namespace nnb::adapters
