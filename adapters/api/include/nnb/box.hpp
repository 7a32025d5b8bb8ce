#pragma once
// An axis-aligned box and the squared distance to it, for adapters that prune by boxes in double.
namespace nnb {

struct Box {
  double lo[3];
  double hi[3];
};

/// Squared distance (m^2) from the query to the box, 0 inside. It is summed in sq_dist_m2's order, and
/// rounding is monotone, so it never exceeds the computed distance of a point in the box: pruning is exact.
inline double sq_dist_to_box_m2(const double* q, const Box& box) {
  double d[3];
  for (int a = 0; a < 3; ++a) {
    d[a] = q[a] < box.lo[a] ? box.lo[a] - q[a] : (q[a] > box.hi[a] ? q[a] - box.hi[a] : 0.0);
  }
  return d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
}

}  // namespace nnb
