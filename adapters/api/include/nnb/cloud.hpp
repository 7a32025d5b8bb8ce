#pragma once
// Point clouds as the whole project sees them: 3 x N, double precision, metres.
#include <Eigen/Core>

#include <cstddef>
#include <stdexcept>
#include <string>

namespace nnb {

/// A point cloud: one column per point (x, y, z in metres), contiguous per point.
using Cloud = Eigen::Matrix<double, 3, Eigen::Dynamic>;

/// Index of a point in a cloud. 32 bits is enough for the 16M-point scans of the paper.
using PointIndex = std::uint32_t;

/// Bad input from a user (a file, a name, a parameter): the message is one line, meant to be printed.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Returns the index of the first point with a non-finite coordinate, or -1 when all are finite.
inline Eigen::Index first_non_finite(const Cloud& cloud) {
  for (Eigen::Index i = 0; i < cloud.cols(); ++i) {
    if (!cloud.col(i).allFinite()) return i;
  }
  return -1;
}

/// Squared distance between two points in square metres, summed in a fixed order so that every
/// adapter that recomputes distances in double gets the very same bits as brute force.
inline double sq_dist_m2(const double* a, const double* b) {
  const double dx = a[0] - b[0];
  const double dy = a[1] - b[1];
  const double dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

}  // namespace nnb
