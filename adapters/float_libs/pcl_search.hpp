#pragma once
// The searches PCL's k-d tree and octree share (nearestKSearch, radiusSearch on PointXYZ), made exact the
// same way for both: float coordinates in the model's frame, a wider float search, double refinement.
#include "exact_knn.hpp"
#include "float_frame.hpp"
#include "nnb/search_index.hpp"

#include <pcl/point_types.h>

#include <vector>

namespace nnb::adapters {

/// Point p (metres, double) as a PCL point in frame's float coordinates.
inline pcl::PointXYZ to_pcl(const FloatFrame& frame, const double* p) {
  return pcl::PointXYZ(frame.coord(p, 0), frame.coord(p, 1), frame.coord(p, 2));
}

/// Exact k nearest (squared metres) from a PCL search's float k+1 nearest, plus a radius search on near-ties.
template <class PclSearch>
void pcl_exact_knn(PclSearch& search, const FloatFrame& frame, const Cloud& model, const Cloud& queries, int k,
                   Neighbours& out) {
  pcl::Indices indices;
  std::vector<float> sq_dists;
  const auto knn_row = [&](std::size_t q, std::size_t n, FloatCandidates& row) {
    search.nearestKSearch(to_pcl(frame, queries.col(static_cast<Eigen::Index>(q)).data()),
                          static_cast<pcl::uindex_t>(n), indices, row.sq_dists_m2);
    row.indices.assign(indices.begin(), indices.end());
  };
  const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
    search.radiusSearch(to_pcl(frame, queries.col(static_cast<Eigen::Index>(q)).data()), search_m, indices, sq_dists,
                        0);
    row.assign(indices.begin(), indices.end());
  };
  exact_knn(model, queries, static_cast<std::size_t>(k), frame, knn_row, radius_row, out);
}

/// Exact k nearest within max_dist_m from PCL's radius search limited to k+1 points (max_nn), which PCL's
/// k-d tree hands to FLANN as max_neighbors: a pruned ranged search.
template <class PclSearch>
void pcl_exact_ranged(PclSearch& search, const FloatFrame& frame, const Cloud& model, const Cloud& queries, int k,
                      double max_dist_m, Neighbours& out) {
  pcl::Indices indices;
  std::vector<float> sq_dists;
  const auto ranged_row = [&](std::size_t q, std::size_t n, double search_m, FloatCandidates& row) {
    search.radiusSearch(to_pcl(frame, queries.col(static_cast<Eigen::Index>(q)).data()), search_m, indices,
                        row.sq_dists_m2, static_cast<unsigned int>(n));
    row.indices.assign(indices.begin(), indices.end());
  };
  const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
    search.radiusSearch(to_pcl(frame, queries.col(static_cast<Eigen::Index>(q)).data()), search_m, indices, sq_dists,
                        0);
    row.assign(indices.begin(), indices.end());
  };
  exact_ranged(model, queries, static_cast<std::size_t>(k), max_dist_m, frame, ranged_row, radius_row, out);
}

/// Every point within radius_m (inclusive, in double) from a PCL search run slightly wider in float.
template <class PclSearch>
void pcl_exact_radius(PclSearch& search, const FloatFrame& frame, const Cloud& model, const Cloud& queries,
                      double radius_m, Neighbours& out) {
  out.reset(static_cast<std::size_t>(queries.cols()));
  pcl::Indices indices;
  std::vector<float> sq_dists;
  for (Eigen::Index q = 0; q < queries.cols(); ++q) {
    const double* query = queries.col(q).data();
    search.radiusSearch(to_pcl(frame, query), frame.search_radius_m(query, radius_m), indices, sq_dists, 0);
    for (const auto index : indices) out.push(static_cast<PointIndex>(index), 0.0);
    out.end_query();
  }
  recompute_sq_dists(model, queries, out);
  filter_by_sq_dist(radius_m * radius_m, out);
}

}  // namespace nnb::adapters
