#pragma once
// What the float libraries (FLANN, PCL) share: points handed over in float relative to the model's
// bounding-box centre (so that float keeps ~1e-7 of the cloud's extent, not of its distance from the
// origin, which matters for georeferenced scans), and the radius to search with so that float
// rounding never loses a point that counts in double. Results are then recomputed in double and
// filtered by the exact rule (recompute_sq_dists + filter_by_sq_dist); k-NN is made exact in exact_knn.hpp.
#include "nnb/cloud.hpp"

#include <algorithm>
#include <cmath>

namespace nnb::adapters {

class FloatFrame {
 public:
  /// Sets the origin to the centre of model's bounding box and records its extent.
  void fit(const Cloud& model) {
    const Eigen::Vector3d lo = model.rowwise().minCoeff();
    const Eigen::Vector3d hi = model.rowwise().maxCoeff();
    origin_ = 0.5 * (lo + hi);
    model_magnitude_m_ = 0.5 * (hi - lo).maxCoeff();
  }

  /// Coordinate d (0, 1, 2) of point p relative to the origin, in float metres.
  float coord(const double* p, int d) const { return static_cast<float>(p[d] - origin_[d]); }

  /// Radius in metres to hand a float library so that every point with sq_dist_m2 <= radius_m^2 (double)
  /// is found even after rounding coordinates and distances to float: 1e-5 relative covers the float
  /// arithmetic on distances, 1e-6 of the largest coordinate covers rounding the coordinates (each is
  /// off by at most 6e-8 of it), and the floor keeps radius 0 positive for libraries that test d < r.
  double search_radius_m(const double* query, double radius_m) const {
    const double query_magnitude_m = std::max({std::abs(query[0] - origin_[0]), std::abs(query[1] - origin_[1]),
                                               std::abs(query[2] - origin_[2])});
    const double magnitude_m = std::max(model_magnitude_m_, query_magnitude_m);
    return radius_m * (1.0 + 1e-5) + 1e-6 * magnitude_m + 1e-12;
  }

  /// Whether every point at float distance >= float_dist_m (metres) from query lies beyond radius_m in
  /// double: the converse of search_radius_m, with the same error bound.
  bool surely_beyond(const double* query, double float_dist_m, double radius_m) const {
    return float_dist_m > search_radius_m(query, radius_m);
  }

 private:
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double model_magnitude_m_ = 0.0;
};

}  // namespace nnb::adapters
