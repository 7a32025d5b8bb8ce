#pragma once
// What both nanoflann adapters (Debian's 1.4.3 and the newest, each in its own translation unit and namespace)
// hand nanoflann alike. Includes no nanoflann header, so that each adapter sees only its own version's.
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace nnb::adapters::nanoflann_source {

// The interface nanoflann asks of a data set: point count and coordinate access, over the model in place.
struct CloudSource {
  const Cloud* cloud = nullptr;
  std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(cloud->cols()); }
  double kdtree_get_pt(PointIndex index, std::size_t dim) const {
    return (*cloud)(static_cast<Eigen::Index>(dim), static_cast<Eigen::Index>(index));
  }
  template <class BoundingBox>
  bool kdtree_get_bbox(BoundingBox&) const { return false; }  // let nanoflann compute it
};

// Squared search bound (m^2) that nanoflann's strict `<` turns into at least our inclusive limit:
// a relative and an absolute margin for rounding in its incremental cell distances, then one ulp.
inline double inflated_sq_bound_m2(double limit_m, const double* query) {
  const double scale = std::max({std::abs(query[0]), std::abs(query[1]), std::abs(query[2]), limit_m});
  const double padded_m = limit_m + 1e-12 * scale;
  return next_up(padded_m * padded_m);
}

// Appends one query's row: those of the count found whose squared distance is within limit_sq_m2 (the
// search ran with the inflated bound).
inline void append_within(double limit_sq_m2, const PointIndex* indices, const double* sq_dists, std::size_t count,
                          Neighbours& out) {
  for (std::size_t i = 0; i < count; ++i) {
    if (sq_dists[i] <= limit_sq_m2) out.push(indices[i], sq_dists[i]);
  }
  out.end_query();
}

// The k nearest of each query (at most the model's size), by the tree's own knnSearch.
template <class Tree>
void knn_rows(const Tree& tree, const Cloud& queries, int k, std::size_t model_size, Neighbours& out) {
  const std::size_t keep = std::min<std::size_t>(static_cast<std::size_t>(k), model_size);
  std::vector<PointIndex> indices(keep);
  std::vector<double> sq_dists(keep);
  out.reset(static_cast<std::size_t>(queries.cols()), keep * static_cast<std::size_t>(queries.cols()));
  for (Eigen::Index q = 0; q < queries.cols(); ++q) {
    const std::size_t found = tree.knnSearch(queries.col(q).data(), keep, indices.data(), sq_dists.data());
    for (std::size_t i = 0; i < found; ++i) out.push(indices[i], sq_dists[i]);
    out.end_query();
  }
}

}  // namespace nnb::adapters::nanoflann_source
