#pragma once
// Point clouds as the whole project sees them: 3 x N, double precision, metres.
#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <sstream>
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

/// The coordinate contract: every coordinate of a model or query point satisfies |c| <= this (metres).
/// Why 1e15: the float adapters (adapters/float_libs/float_frame.hpp) hand libraries coordinates relative
/// to the model's centre, so a coordinate is at most 2e15 there and a squared distance at most
/// 3 * (4e15)^2 ~ 5e31, far below float's 3.4e38; their search margins are relative (1e-5 of the radius,
/// 1e-6 of the magnitude), so rounding stays covered at any magnitude that does not overflow. In double,
/// volumes and squared distances (R-tree areas, (2e15)^3 ~ 1e46) stay finite. Beyond ~5e18 float squared
/// distances overflow (PCL answered wrongly at 1e20), and at 1e200 double squares overflow too.
inline constexpr double kMaxAbsCoordinate_m = 1e15;

/// Returns the index of the first point of [first, last) with a coordinate beyond kMaxAbsCoordinate_m
/// (non-finite ones included), or -1.
inline Eigen::Index first_out_of_range(const Cloud& cloud, Eigen::Index first, Eigen::Index last) {
  for (Eigen::Index i = first; i < last; ++i) {
    for (int d = 0; d < 3; ++d) {
      if (!(std::abs(cloud(d, i)) <= kMaxAbsCoordinate_m)) return i;  // NaN fails too
    }
  }
  return -1;
}

inline Eigen::Index first_out_of_range(const Cloud& cloud) { return first_out_of_range(cloud, 0, cloud.cols()); }

/// Throws InputError naming what (a file, "query cloud"...) and the first point whose coordinates are
/// non-finite or beyond kMaxAbsCoordinate_m, so that no library ever sees them.
inline void check_coordinate_range(const Cloud& cloud, const std::string& what) {
  const Eigen::Index bad = first_out_of_range(cloud);
  if (bad < 0) return;
  std::ostringstream bound, msg;
  bound << kMaxAbsCoordinate_m;
  msg.precision(17);
  msg << what << ": point " << bad << " (" << cloud(0, bad) << ", " << cloud(1, bad) << ", " << cloud(2, bad)
      << ") has a coordinate beyond the supported range |c| <= " << bound.str() << " m";
  throw InputError(msg.str());
}

/// The columns `which` of from, in that order, into `into` (resized; its memory kept between calls).
template <class Indices>
void gather_columns(const Cloud& from, const Indices& which, Cloud& into) {
  into.resize(3, static_cast<Eigen::Index>(which.size()));
  for (std::size_t i = 0; i < which.size(); ++i) {
    into.col(static_cast<Eigen::Index>(i)) = from.col(static_cast<Eigen::Index>(which[i]));
  }
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
