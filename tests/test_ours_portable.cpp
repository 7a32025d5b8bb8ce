// Our trees built with the plain C++ paths that CPUs other than x86 take (-DOURS_PORTABLE): their answers
// are brute force's, to the bit for double trees. A binary of its own, linking nothing else that includes
// ours/, so that no inline function compiled with the vector paths can stand in for a portable one.
#include "ours/kdtree.hpp"
#include "ours/octree.hpp"
#include "ours/query_order.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#if defined(OURS_SSE2) || defined(OURS_WIDE_SIMD)
#error "test_ours_portable must be built with -DOURS_PORTABLE"
#endif

namespace {

using Points = std::vector<double>;  // x,y,z triples, metres

// Every model point by distance from each query, nearest first, as (squared distance, index): the same
// arithmetic as the trees' double scans (differences, then dx^2 + dy^2 + dz^2 left to right, no FMA).
class BruteForce {
 public:
  BruteForce(const Points& model, const Points& queries) : by_distance_(queries.size() / 3) {
    for (std::size_t q = 0; q < by_distance_.size(); ++q) {
      const double* p = queries.data() + 3 * q;
      for (std::size_t i = 0; i < model.size() / 3; ++i) {
        const double dx = p[0] - model[3 * i], dy = p[1] - model[3 * i + 1], dz = p[2] - model[3 * i + 2];
        by_distance_[q].emplace_back(dx * dx + dy * dy + dz * dz, static_cast<std::uint32_t>(i));
      }
      std::sort(by_distance_[q].begin(), by_distance_[q].end());
    }
  }
  /// Query q's k nearest within the limit, nearest first.
  std::vector<std::pair<double, std::uint32_t>> answer(std::size_t q, int k, double limit_sq_m2) const {
    std::vector<std::pair<double, std::uint32_t>> out;
    for (const auto& n : by_distance_[q]) {
      if (out.size() == static_cast<std::size_t>(k) || !(n.first < limit_sq_m2)) break;
      out.push_back(n);
    }
    return out;
  }

 private:
  std::vector<std::vector<std::pair<double, std::uint32_t>>> by_distance_;
};

Points uniform_cube(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Points p(3 * n);
  for (double& v : p) v = u(rng);
  return p;
}

// A surface with many repeated points and points on common planes: ties and degenerate splits.
Points gridded_with_duplicates(std::size_t n) {
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = double(i % 37) * 0.05, y = double((i / 37) % 23) * 0.05;
    p.insert(p.end(), {x, y, 0.25 * std::sin(x)});
  }
  return p;
}

// Queries scattered about the cloud's box and, in a scan-like order, near its points.
Points queries_near(const Points& model, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> jitter(0.0, 0.02);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  Points q;
  for (std::size_t i = 0; i < n; ++i) q.insert(q.end(), {u(rng), u(rng), u(rng)});
  for (std::size_t i = 0; i < model.size() / 3 && i < n; ++i) {
    for (int d = 0; d < 3; ++d) q.push_back(model[3 * i + d] + jitter(rng));
  }
  return q;
}

const double kInf = std::numeric_limits<double>::infinity();

// Double trees: the same neighbours as brute force with the same squared distances, bit for bit.
template <class Tree>
void expect_exact(const Tree& tree, const BruteForce& truth, const Points& queries, int k, double limit_sq_m2,
                  const std::string& what) {
  SCOPED_TRACE(what + ", k " + std::to_string(k) + ", limit^2 " + std::to_string(limit_sq_m2));
  typename Tree::Buffers buffers;
  std::size_t differ = 0, answered = 0;
  tree.knn_batch(queries.data(), queries.size() / 3, k, limit_sq_m2, buffers,
                 [&](std::size_t i, const std::vector<ours::Neighbour<double>>& got) {
    const auto want = truth.answer(i, k, limit_sq_m2);
    bool same = got.size() == want.size();
    for (std::size_t j = 0; same && j < got.size(); ++j) same = got[j].sq_dist == want[j].first;
    differ += !same;
    ++answered;
  });
  EXPECT_EQ(answered, queries.size() / 3);
  EXPECT_EQ(differ, 0u);
}

// Float trees return a superset of the answer (the caller refines it in double): every true neighbour is
// among what they return.
template <class Tree>
void expect_superset(const Tree& tree, const BruteForce& truth, const Points& queries, int k, double limit_sq_m2) {
  SCOPED_TRACE("float, k " + std::to_string(k) + ", limit^2 " + std::to_string(limit_sq_m2));
  typename Tree::Buffers buffers;
  std::size_t missing = 0;
  tree.knn_batch(queries.data(), queries.size() / 3, k, limit_sq_m2, buffers,
                 [&](std::size_t i, const std::vector<ours::Neighbour<float>>& got) {
    for (const auto& want : truth.answer(i, k, limit_sq_m2)) {
      const auto index = want.second;  // a lambda may capture a structured binding only from C++20
      missing += std::none_of(got.begin(), got.end(), [&](const auto& n) { return n.index == index; });
    }
  });
  EXPECT_EQ(missing, 0u);
}

TEST(OursPortable, KdTreeAnswersAreBruteForces) {
  for (const Points& model : {uniform_cube(3000, 1), gridded_with_duplicates(2500)}) {
    const Points queries = queries_near(model, 600, 2);
    const BruteForce truth(model, queries);
    for (const int bucket : {1, 8, 64}) {
      for (const int threads : {1, 2}) {
        ours::KdTree<double> tree;
        tree.build(model.data(), model.size() / 3, bucket, threads);
        for (const int k : {1, 5}) {
          for (const double limit_sq_m2 : {0.0004, 0.04, kInf}) {
            expect_exact(tree, truth, queries, k, limit_sq_m2, "k-d tree, bucket " + std::to_string(bucket));
          }
        }
      }
    }
  }
  const Points model = uniform_cube(3000, 3), queries = queries_near(model, 600, 4);
  ours::KdTree<float> tree;
  tree.build(model.data(), model.size() / 3, 8);
  for (const double limit_sq_m2 : {0.04, kInf}) expect_superset(tree, BruteForce(model, queries), queries, 3, limit_sq_m2);
}

TEST(OursPortable, OctreeAnswersAreBruteForces) {
  for (const Points& model : {uniform_cube(3000, 5), gridded_with_duplicates(2500)}) {
    const Points queries = queries_near(model, 600, 6);
    const BruteForce truth(model, queries);
    for (const int max_points : {1, 8, 80}) {
      ours::Octree<double> tree;
      tree.build(model.data(), model.size() / 3, max_points, 0.0);
      for (const int k : {1, 5}) {
        for (const double limit_sq_m2 : {0.0004, 0.04, kInf}) {
          expect_exact(tree, truth, queries, k, limit_sq_m2, "octree, leaf " + std::to_string(max_points));
        }
      }
    }
  }
  const Points model = uniform_cube(3000, 7), queries = queries_near(model, 600, 8);
  ours::Octree<float> tree;
  tree.build(model.data(), model.size() / 3, 8, 0.0);
  for (const double limit_sq_m2 : {0.04, kInf}) expect_superset(tree, BruteForce(model, queries), queries, 3, limit_sq_m2);
}

// The portable grid cell (no SSE2 clamp) clamps to the grid, NaN to its first cell.
TEST(OursPortable, GridCellsClampToTheGrid) {
  EXPECT_EQ(ours::detail::grid_cell(0.5, 0.0, 1024.0), 512u);
  EXPECT_EQ(ours::detail::grid_cell(-3.0, 0.0, 1024.0), 0u);
  EXPECT_EQ(ours::detail::grid_cell(7.0, 0.0, 1024.0), 1023u);
  EXPECT_EQ(ours::detail::grid_cell(kInf, 0.0, 1024.0), 1023u);
  EXPECT_EQ(ours::detail::grid_cell(std::numeric_limits<double>::quiet_NaN(), 0.0, 1024.0), 0u);
}

// A batch's Morton order is a permutation along the curve, equal codes in the caller's order.
TEST(OursPortable, MortonOrderIsAPermutationAlongTheCurve) {
  const Points queries = uniform_cube(40000, 9);
  const std::size_t n = queries.size() / 3;
  ours::QueryOrder order;
  ours::morton_order(queries.data(), n, order);
  std::vector<std::uint32_t> sorted = order.order;
  std::sort(sorted.begin(), sorted.end());
  for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);
  std::array<double, 3> lo, hi;
  ours::bounding_box(queries.data(), n, lo, hi);
  std::vector<std::uint64_t> keys(n);
  ours::morton_keys(queries.data(), 0, n, ours::morton_grid(lo, hi), keys.data());
  for (std::size_t s = 1; s < n; ++s) {
    const std::uint64_t a = keys[order.order[s - 1]] >> 32, b = keys[order.order[s]] >> 32;
    ASSERT_LE(a, b) << "at " << s;
    if (a == b) {
      ASSERT_LT(order.order[s - 1], order.order[s]);
    }
  }
  EXPECT_GT(keys[order.order[n - 1]] >> 32, keys[order.order[0]] >> 32) << "every query in one cell";
}

}  // namespace
