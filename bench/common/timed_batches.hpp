#pragma once
// The batches micro_nns and ours_ab both time, made in one place so that they stay the same: Figure 3's pair
// and a scan's points in a fixed random order (the "shuffled" batches).
#include "nnb/cloud.hpp"
#include "nnb/datasets/synthetic.hpp"

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

namespace nnb::bench {

/// The paper's Figure 3: hollow-cube queries against a hollow-sphere model, 60,000 points each (seed 1).
struct Figure3Pair {
  Cloud model, queries;
};

inline Figure3Pair figure3_pair() {
  using nnb::datasets::Shape;
  return {nnb::datasets::make_shape(Shape::hollow_sphere, 60000, 1),
          nnb::datasets::make_shape(Shape::hollow_cube, 60000, 1)};
}

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
