#pragma once
// A scan's points in a fixed random order: the "shuffled" batches of micro_nns and ours_ab, the same in both.
#include "nnb/cloud.hpp"

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

namespace nnb::bench {

/// The columns of scan in one fixed random order (seed 42).
inline Cloud shuffled_scan(const Cloud& scan) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(scan.cols()));
  std::iota(order.begin(), order.end(), Eigen::Index(0));
  std::shuffle(order.begin(), order.end(), std::mt19937_64(42));
  Cloud out(3, scan.cols());
  for (std::size_t i = 0; i < order.size(); ++i) out.col(Eigen::Index(i)) = scan.col(order[i]);
  return out;
}

}  // namespace nnb::bench
