// Our k-d tree and octree: structural invariants, and exact answers (compared by distance, to the
// bit) against brute force on awkward clouds: duplicates, flat, collinear, huge offsets, tiny extents.
#include "cross_check.hpp"
#include "nnb/datasets/synthetic.hpp"
#include "nnb/registry.hpp"
#include "ours/kdtree.hpp"
#include "ours/neighbour_graph.hpp"
#include "ours/octree.hpp"
#include "ours/query_order.hpp"

#include <gtest/gtest.h>

// The x86 build must take the SSE2 paths (test_ours_portable checks the others).
#if defined(__SSE2__) && !defined(OURS_SSE2)
#error "ours/ built without its SSE2 paths on an SSE2 CPU"
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif
#if defined(OURS_WIDE_SIMD)
#include <cpuid.h>
#include <cstdlib>
#endif

namespace {

using nnb::Cloud;
using nnb::Neighbours;
using nnb::Params;

// ---------- clouds ----------

Cloud sphere(std::size_t n) { return nnb::datasets::make_shape(nnb::datasets::Shape::hollow_sphere, n, 7); }

Cloud with_duplicates(std::size_t n) {
  // Points snapped to a coarse grid (many exact duplicates), plus 50 copies of one point.
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> cell(0, 6);
  Cloud c(3, static_cast<Eigen::Index>(n));
  for (Eigen::Index i = 0; i < c.cols(); ++i) {
    if (i < 50) c.col(i) << 0.5, 0.5, 0.5;
    else c.col(i) << 0.25 * cell(rng), 0.25 * cell(rng), 0.25 * cell(rng);
  }
  return c;
}

Cloud flat(std::size_t n) {
  Cloud c = sphere(n);
  c.row(2).setConstant(1.25);
  return c;
}

Cloud collinear(std::size_t n) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> t(-1, 1);
  Cloud c(3, static_cast<Eigen::Index>(n));
  for (Eigen::Index i = 0; i < c.cols(); ++i) {
    const double s = t(rng);
    c.col(i) << 0.3 + s, -0.2 + 2 * s, 0.7 - 0.5 * s;
  }
  return c;
}

// A cluster whose spread (1e-12 m) is far below a float's resolution at its distance from the
// cloud's centre: no float cut separates it, so the k-d tree must keep it in one oversized bucket.
Cloud unsplittable_cluster(std::size_t n) {
  Cloud c = sphere(n);
  for (Eigen::Index i = 0; i < 100 && i < c.cols(); ++i) c.col(i) << 0.9 + 1e-12 * double(i), 0.1 - 1e-12 * double(i % 7), 0.2;
  return c;
}

Cloud shifted(Cloud c, double scale, double offset) {
  c *= scale;
  c.array() += offset;
  return c;
}

// Queries on model points, near them, and far outside the root cube.
Cloud queries_for(const Cloud& model, double extent_m, std::size_t n) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<Eigen::Index> pick(0, model.cols() - 1);
  std::normal_distribution<double> jitter(0, 1);
  Cloud q(3, static_cast<Eigen::Index>(n));
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    const Eigen::Vector3d p = model.col(pick(rng));
    const Eigen::Vector3d noise(jitter(rng), jitter(rng), jitter(rng));
    switch (i % 4) {
      case 0: q.col(i) = p; break;
      case 1: q.col(i) = p + 0.01 * extent_m * noise; break;
      case 2: q.col(i) = p + 0.2 * extent_m * noise; break;
      default: q.col(i) = p + 3.0 * extent_m * noise; break;  // well outside the root cube
    }
  }
  return q;
}

// The same queries as a scanner would deliver them, one after the other along the surface: sorted by
// their Morton code on a 1024^3 grid over their bounds.
Cloud in_scan_order(const Cloud& queries) {
  const Eigen::Vector3d lo = queries.rowwise().minCoeff(), hi = queries.rowwise().maxCoeff();
  std::vector<std::pair<std::uint64_t, Eigen::Index>> keyed;
  for (Eigen::Index i = 0; i < queries.cols(); ++i) {
    std::uint64_t code = 0;
    for (int bit = 9; bit >= 0; --bit) {
      for (int d = 0; d < 3; ++d) {
        const double unit = (queries(d, i) - lo[d]) / std::max(hi[d] - lo[d], 1e-300);
        code = (code << 1) | ((static_cast<std::uint64_t>(unit * 1023.0) >> bit) & 1u);
      }
    }
    keyed.emplace_back(code, i);
  }
  std::sort(keyed.begin(), keyed.end());
  Cloud sorted(3, queries.cols());
  for (Eigen::Index i = 0; i < queries.cols(); ++i) sorted.col(i) = queries.col(keyed[static_cast<std::size_t>(i)].second);
  return sorted;
}

// Scan-ordered queries, then the same in random order: the k-d tree's search switches from reusing the
// last descent to descending from the root and back.
Cloud scan_then_random(const Cloud& queries) {
  Cloud both(3, 2 * queries.cols());
  both << in_scan_order(queries), queries;
  return both;
}

// ---------- exact comparison ----------

// Both answers, row by row: same counts and the very same sorted distances (bit for bit).
std::string exact_mismatch(const Cloud& model, const Cloud& queries, const Neighbours& expected,
                           const Neighbours& got, bool sorted_rows) {
  if (auto text = nnb::testing::compare_with_reference(model, queries, expected, got, sorted_rows); !text.empty()) {
    return text;
  }
  for (std::size_t q = 0; q < expected.n_queries(); ++q) {
    std::vector<double> a(expected.sq_dists.begin() + expected.offsets[q], expected.sq_dists.begin() + expected.offsets[q + 1]);
    std::vector<double> b(got.sq_dists.begin() + got.offsets[q], got.sq_dists.begin() + got.offsets[q + 1]);
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    if (a != b) {
      return "query " + std::to_string(q) + ": distances differ in their last bits\n  brute force:" +
             nnb::testing::row_text(expected, q) + "\n  ours:       " + nnb::testing::row_text(got, q);
    }
  }
  return "";
}

struct Variant {
  std::string adapter;
  Params params;
  std::string label() const {
    std::string text = adapter;
    for (const auto& [k, v] : params) text += " " + k + "=" + v;
    return text;
  }
};

std::vector<Variant> variants() {
  std::vector<Variant> all;
  for (const char* scalar : {"double", "float"}) {
    for (const char* bucket : {"1", "2", "8", "1000"}) {
      all.push_back({"ours_kdtree", {{"scalar", scalar}, {"bucket_size", bucket}}});
    }
    for (const char* leaf : {"1", "2", "8", "1000"}) {
      all.push_back({"ours_octree", {{"scalar", scalar}, {"max_points_per_leaf", leaf}}});
    }
    all.push_back({"ours_octree", {{"scalar", scalar}, {"max_points_per_leaf", "1"}, {"min_cell_size_m", "0.05"}}});
    for (const char* order : {"morton", "caller"}) {
      all.push_back({"ours_kdtree", {{"scalar", scalar}, {"bucket_size", "8"}, {"order", order}}});
      all.push_back({"ours_octree", {{"scalar", scalar}, {"max_points_per_leaf", "8"}, {"order", order}}});
    }
  }
  return all;
}

// One query kind at one limit (k-NN: none; radius: no k).
struct QueryCase {
  nnb::SearchKind kind;
  int k;
  double max_dist_m;
  std::string label;
  Neighbours expected;
  void run(const nnb::SearchIndex& index, const Cloud& queries, Neighbours& out) const {
    index.search(kind, queries, k, max_dist_m, out);
  }
};

// Every query kind at every limit, brute force's answers computed once for all variants.
std::vector<QueryCase> brute_force_cases(const Cloud& model, const Cloud& queries, double extent_m) {
  using nnb::SearchKind;
  std::vector<QueryCase> cases;
  for (int k : {1, 2, 4, 9, 40}) {
    cases.push_back({SearchKind::knn, k, 0.0, "knn k=" + std::to_string(k), {}});
    for (double fraction : {0.0, 0.01, 0.1, 0.5}) {
      const double max_dist_m = fraction * extent_m;
      cases.push_back({SearchKind::ranged, k, max_dist_m,
                       "ranged k=" + std::to_string(k) + " d=" + std::to_string(max_dist_m), {}});
    }
  }
  for (double fraction : {0.0, 0.02, 0.2}) {
    cases.push_back({SearchKind::radius, 0, fraction * extent_m, "radius " + std::to_string(fraction * extent_m), {}});
  }
  auto brute = nnb::make_adapter("brute_force");
  brute->build(model);
  for (auto& c : cases) c.run(*brute, queries, c.expected);
  return cases;
}

// Every variant, every query kind, against brute force; the limits scale with the cloud's extent.
void check_all(const Cloud& model, double extent_m) {
  const Cloud queries = scan_then_random(queries_for(model, extent_m, 240));
  const std::vector<QueryCase> cases = brute_force_cases(model, queries, extent_m);
  for (const auto& v : variants()) {
    SCOPED_TRACE(v.label());
    auto index = nnb::make_adapter(v.adapter, v.params);
    index->build(model);
    Neighbours got;
    for (const auto& c : cases) {
      c.run(*index, queries, got);
      ASSERT_EQ("", exact_mismatch(model, queries, c.expected, got, c.kind != nnb::SearchKind::radius)) << c.label;
    }
  }
}

TEST(OursExact, SphereAgainstBruteForce) { check_all(sphere(3000), 2.0); }
TEST(OursExact, ManyDuplicatePoints) { check_all(with_duplicates(3000), 1.5); }
TEST(OursExact, FlatCloud) { check_all(flat(3000), 2.0); }
TEST(OursExact, CollinearCloud) { check_all(collinear(3000), 4.0); }
TEST(OursExact, HugeCoordinates) { check_all(shifted(sphere(3000), 1.0, 1e6), 2.0); }
TEST(OursExact, TinyExtents) { check_all(shifted(sphere(3000), 1e-6, 0.3), 2e-6); }
TEST(OursExact, ClusterNoFloatCutSeparates) { check_all(unsplittable_cluster(2000), 2.0); }
TEST(OursExact, HugeOffsetTinyExtent) { check_all(shifted(sphere(2000), 1e-3, -2e6), 2e-3); }

TEST(OursExact, FloatAndDoubleAgreeWhereNotTied) {
  const Cloud model = sphere(5000);
  const Cloud queries = queries_for(model, 2.0, 400);
  auto brute = nnb::make_adapter("brute_force");
  brute->build(model);
  Neighbours reference;
  brute->knn(queries, 2, reference);
  for (const char* adapter : {"ours_kdtree", "ours_octree"}) {
    auto single = nnb::make_adapter(adapter, {{"scalar", "float"}});
    auto twice = nnb::make_adapter(adapter, {{"scalar", "double"}});
    single->build(model);
    twice->build(model);
    Neighbours a, b;
    single->knn(queries, 1, a);
    twice->knn(queries, 1, b);
    std::size_t compared = 0;
    for (std::size_t q = 0; q < static_cast<std::size_t>(queries.cols()); ++q) {
      const std::size_t o = reference.offsets[q];
      if (reference.sq_dists[o] == reference.sq_dists[o + 1]) continue;  // a tie: either index is right
      ++compared;
      EXPECT_EQ(a.indices[q], b.indices[q]) << adapter << " query " << q;
      EXPECT_EQ(a.sq_dists[q], b.sq_dists[q]) << adapter << " query " << q;
    }
    EXPECT_GT(compared, static_cast<std::size_t>(queries.cols()) / 2);
  }
}

// ---------- k-d tree invariants ----------

template <typename T>
void check_kdtree(const Cloud& model, int bucket) {
  SCOPED_TRACE("bucket " + std::to_string(bucket));
  ours::KdTree<T> tree;
  tree.build(model.data(), static_cast<std::size_t>(model.cols()), bucket);
  const auto& nodes = tree.nodes();
  EXPECT_EQ(tree.node_bytes(), nodes.size() * 8u);
  EXPECT_EQ(tree.index_bytes(), static_cast<std::size_t>(model.cols()) * 4u);
  EXPECT_EQ(tree.point_copy_bytes(), static_cast<std::size_t>(model.cols()) * 3u * sizeof(T));
  std::vector<int> times_seen(static_cast<std::size_t>(model.cols()), 0);
  std::vector<int> slot_seen(static_cast<std::size_t>(model.cols()), 0);
  // Walk the tree with each node's cell, checking that every leaf point lies inside its cell.
  struct Frame {
    std::uint32_t node;
    std::array<T, 3> lo, hi;
  };
  const T inf = std::numeric_limits<T>::infinity();
  std::vector<Frame> stack{{0, {-inf, -inf, -inf}, {inf, inf, inf}}};
  std::size_t leaves = 0;
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    ASSERT_LT(f.node, nodes.size());
    const auto& node = nodes[f.node];
    if (node.is_leaf()) {
      ++leaves;
      const std::uint32_t begin = node.bucket, count = node.right_or_size();
      ASSERT_LE(begin + count, model.cols());
      ASSERT_GE(count, 1u);
      for (std::uint32_t i = begin; i < begin + count; ++i) {
        ++slot_seen[i];
        const std::uint32_t original = tree.indices()[i];
        ++times_seen[original];
        for (int d = 0; d < 3; ++d) {
          const T v = tree.coord(i, d);
          EXPECT_EQ(v, T(model(d, original) - (std::is_same_v<T, float> ? tree.origin()[d] : 0.0)));
          EXPECT_GE(v, f.lo[d]);
          EXPECT_LE(v, f.hi[d]);
        }
      }
      if (count > static_cast<std::uint32_t>(bucket)) {
        // Only allowed when the bucket cannot be split: on every axis its points are equal, or no
        // float plane lies between them (tiny extents far from the origin).
        for (int d = 0; d < 3; ++d) {
          T lo = tree.coord(begin, d), hi = lo;
          for (std::uint32_t i = begin + 1; i < begin + count; ++i) {
            lo = std::min(lo, tree.coord(i, d));
            hi = std::max(hi, tree.coord(i, d));
          }
          // The lowest float plane at or above lo must lie above hi (floats in order: bisect).
          std::int64_t a = -0x7f7fffff, b = 0x7f7fffff;
          auto as_float = [](std::int64_t key) {
            const std::uint32_t bits = key < 0 ? (std::uint32_t(-key) | 0x80000000u) : std::uint32_t(key);
            float f;
            std::memcpy(&f, &bits, sizeof f);
            return f;
          };
          while (a < b) {
            const std::int64_t mid = a + (b - a) / 2;
            if (tree.plane(d, as_float(mid)) >= lo) b = mid;
            else a = mid + 1;
          }
          EXPECT_TRUE(lo == hi || tree.plane(d, as_float(a)) > hi)
              << "an oversized bucket that a float plane could split on axis " << d;
        }
      }
      continue;
    }
    Frame left = f, right = f;
    left.node = f.node + 1;
    left.hi[node.dim()] = tree.plane(node.dim(), node.cut);
    right.node = node.right_or_size();
    right.lo[node.dim()] = tree.plane(node.dim(), node.cut);
    ASSERT_GT(right.node, left.node);
    stack.push_back(left);
    stack.push_back(right);
  }
  EXPECT_EQ(nodes.size(), 2 * leaves - 1);
  for (std::size_t i = 0; i < times_seen.size(); ++i) {
    ASSERT_EQ(times_seen[i], 1) << "point " << i;
    ASSERT_EQ(slot_seen[i], 1) << "slot " << i;
  }
}

TEST(OursKdTree, Invariants) {
  for (const Cloud& c : {sphere(5000), with_duplicates(3000), flat(2000), collinear(2000),
                         shifted(sphere(2000), 1.0, 1e6), shifted(sphere(2000), 1e-6, 0.0),
                         unsplittable_cluster(2000)}) {
    for (int bucket : {1, 2, 8, 5000}) {
      check_kdtree<float>(c, bucket);
      check_kdtree<double>(c, bucket);
    }
  }
}

// Queries in scan order take the search that starts from the last descent, random ones do not, and both
// answer as single queries (each descending from the root) do, to the bit.
template <typename T>
void check_descent_reuse(const Cloud& model, int bucket, int k, double limit_sq_m2) {
  SCOPED_TRACE("bucket " + std::to_string(bucket) + ", k " + std::to_string(k) + ", limit^2 " + std::to_string(limit_sq_m2));
  ours::KdTree<T> tree;
  tree.build(model.data(), static_cast<std::size_t>(model.cols()), bucket);
  // A scan: every model point, a little off, in scan order; and random queries, near and far.
  std::mt19937_64 rng(13);
  std::normal_distribution<double> jitter(0, 1e-3);
  Cloud near = model;
  for (Eigen::Index i = 0; i < near.cols(); ++i) near.col(i) += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
  const Cloud scan = in_scan_order(near);
  const Cloud random = queries_for(model, 2.0, 2000);
  typename ours::KdTree<T>::Buffers batch_buffers, single_buffers;
  for (const Cloud* queries : {&scan, &random}) {
    const std::size_t n = static_cast<std::size_t>(queries->cols());
    std::size_t differ = 0;
    const std::size_t reused = tree.knn_batch(queries->data(), n, k, limit_sq_m2, batch_buffers,
                                              [&](std::size_t i, const std::vector<ours::Neighbour<T>>& got) {
      tree.knn(queries->data() + 3 * i, k, limit_sq_m2, single_buffers);
      const auto& want = single_buffers.best;
      bool same = got.size() == want.size();
      for (std::size_t j = 0; same && j < got.size(); ++j) same = got[j].sq_dist == want[j].sq_dist;
      differ += same ? 0 : 1;
    });
    EXPECT_EQ(differ, 0u) << (queries == &scan ? "scan order" : "random order");
    // Buckets of one point rarely hold two queries in a row: only larger ones must reuse.
    if (queries == &random) {
      EXPECT_LT(reused, n / 10) << "random queries should descend from the root";
    } else if (bucket >= 8) {
      EXPECT_GT(reused, n / 2) << "scan-ordered queries should reuse the last descent";
    }
  }
}

TEST(OursKdTree, ScanOrderedQueriesReuseTheLastDescent) {
  for (const Cloud& c : {sphere(20000), with_duplicates(3000)}) {
    for (int bucket : {1, 8, 32}) {
      for (int k : {1, 5, 40}) {
        for (double limit_sq_m2 : {0.0, 0.01, 0.25, std::numeric_limits<double>::infinity()}) {
          check_descent_reuse<double>(c, bucket, k, limit_sq_m2);
          check_descent_reuse<float>(c, bucket, k, limit_sq_m2);
        }
      }
    }
  }
}

TEST(OursKdTree, ClusterNoFloatCutSeparatesStaysOneBucket) {
  const Cloud c = unsplittable_cluster(2000);
  ours::KdTree<double> tree;
  tree.build(c.data(), 2000, 8);
  std::uint32_t largest = 0;
  for (const auto& node : tree.nodes()) {
    if (node.is_leaf()) largest = std::max(largest, node.right_or_size());
  }
  EXPECT_EQ(largest, 100u);  // the cluster, whole; everything else in buckets of at most 8
}

// Built on threads, the tree is the one built on one: the same nodes, the same order of points, the same
// copies (clouds large enough for the subtrees below the top splits to go to other threads).
template <typename T>
void expect_same_tree_on_threads(const Cloud& model) {
  ours::KdTree<T> one, many;
  one.build(model.data(), static_cast<std::size_t>(model.cols()), 48, 1);
  for (int threads : {2, 3, 8}) {
    many.build(model.data(), static_cast<std::size_t>(model.cols()), 48, threads);
    ASSERT_EQ(many.nodes().size(), one.nodes().size()) << threads << " threads";
    EXPECT_EQ(std::memcmp(many.nodes().data(), one.nodes().data(), one.nodes().size() * sizeof(one.nodes()[0])), 0)
        << threads << " threads";
    EXPECT_TRUE(std::equal(one.indices().begin(), one.indices().end(), many.indices().begin())) << threads << " threads";
    bool same_copies = true;
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      for (int d = 0; d < 3; ++d) same_copies &= one.coord(std::size_t(i), d) == many.coord(std::size_t(i), d);
    }
    EXPECT_TRUE(same_copies) << threads << " threads";
  }
}

TEST(OursKdTree, BuiltOnThreadsAsOnOne) {
  const Cloud model = sphere(300000);
  expect_same_tree_on_threads<double>(model);
  expect_same_tree_on_threads<float>(model);
  expect_same_tree_on_threads<double>(with_duplicates(300000));
}

TEST(OursKdTree, NodesAreEightBytes) {
  EXPECT_EQ(sizeof(ours::KdTree<float>::Node), 8u);
  EXPECT_EQ(sizeof(ours::KdTree<double>::Node), 8u);
  EXPECT_EQ(sizeof(ours::Octree<float>::Node), 8u);
  EXPECT_EQ(sizeof(ours::Octree<double>::Node), 8u);
}

// ---------- octree invariants ----------

template <typename T>
void check_octree(const Cloud& model, int max_points, double min_cell_m) {
  SCOPED_TRACE("max points " + std::to_string(max_points) + ", min cell " + std::to_string(min_cell_m));
  using Tree = ours::Octree<T>;
  Tree tree;
  tree.build(model.data(), static_cast<std::size_t>(model.cols()), max_points, min_cell_m);
  const auto& nodes = tree.nodes();
  EXPECT_EQ(tree.node_bytes(), nodes.size() * 8u);
  EXPECT_EQ(tree.point_copy_bytes(), static_cast<std::size_t>(model.cols()) * 3u * sizeof(T));
  std::vector<int> times_seen(static_cast<std::size_t>(model.cols()), 0);
  std::vector<int> slot_seen(static_cast<std::size_t>(model.cols()), 0);
  std::vector<char> node_seen(nodes.size(), 0);
  auto check_leaf = [&](const typename Tree::Node& leaf, const std::array<std::uint32_t, 3>& base, int level) {
    ASSERT_GE(leaf.word, 1u);
    ASSERT_LE(leaf.first + leaf.word, model.cols());
    const std::uint32_t size = 1u << (Tree::kMaxLevel - level);
    for (std::uint32_t i = leaf.first; i < leaf.first + leaf.word; ++i) {
      ++slot_seen[i];
      const std::uint32_t original = tree.indices()[i];
      ++times_seen[original];
      for (int d = 0; d < 3; ++d) {
        const std::uint32_t cell = tree.to_int(d, model(d, original));
        EXPECT_GE(cell, base[d]);
        EXPECT_LT(cell, base[d] + size);
        // The cell in metres, with a margin for the rounding of the integer mapping.
        const double unit_m = tree.side_m() / double(1u << Tree::kMaxLevel);
        const double lo_m = tree.cube_lo()[d] + base[d] * unit_m, hi_m = lo_m + size * unit_m;
        const double margin = unit_m * 1e-6 + 1e-15 * std::abs(model(d, original));
        EXPECT_GE(model(d, original), lo_m - margin);
        EXPECT_LE(model(d, original), hi_m + margin);
      }
    }
    const double cell_m = tree.side_m() / double(1u << level);
    if (leaf.word > static_cast<std::uint32_t>(max_points)) {
      EXPECT_TRUE(level == Tree::kMaxLevel || cell_m / 2 < min_cell_m) << "leaf of " << leaf.word << " points";
    }
  };
  if (tree.root_is_leaf()) {
    check_leaf(nodes[0], {0, 0, 0}, 0);
  } else {
    struct Frame {
      std::uint32_t node;
      std::array<std::uint32_t, 3> base;
      int level;
    };
    std::vector<Frame> stack{{0, {0, 0, 0}, 0}};
    node_seen[0] = 1;
    while (!stack.empty()) {
      const Frame f = stack.back();
      stack.pop_back();
      const auto& node = nodes[f.node];
      ASSERT_NE(node.valid(), 0u);
      ASSERT_EQ(node.leaves() & ~node.valid(), 0u);
      const std::uint32_t half = 1u << (Tree::kMaxLevel - f.level - 1);
      std::uint32_t slot = node.first;
      for (unsigned j = 0; j < 8; ++j) {
        if (!(node.valid() & (1u << j))) continue;
        ASSERT_LT(slot, nodes.size());
        ASSERT_EQ(node_seen[slot], 0) << "node reached twice";
        node_seen[slot] = 1;
        std::array<std::uint32_t, 3> base = f.base;
        for (int d = 0; d < 3; ++d) base[d] += ((j >> d) & 1u) ? half : 0;
        if (node.leaves() & (1u << j)) check_leaf(nodes[slot], base, f.level + 1);
        else stack.push_back({slot, base, f.level + 1});
        ++slot;
      }
    }
    for (std::size_t i = 0; i < node_seen.size(); ++i) ASSERT_EQ(node_seen[i], 1) << "unreachable node " << i;
  }
  for (std::size_t i = 0; i < times_seen.size(); ++i) {
    ASSERT_EQ(times_seen[i], 1) << "point " << i;
    ASSERT_EQ(slot_seen[i], 1) << "slot " << i;
  }
}

TEST(OursOctree, Invariants) {
  for (const Cloud& c : {sphere(5000), with_duplicates(3000), flat(2000), collinear(2000),
                         shifted(sphere(2000), 1.0, 1e6), shifted(sphere(2000), 1e-6, 0.0)}) {
    for (int leaf : {1, 2, 8, 5000}) {
      check_octree<float>(c, leaf, 0.0);
      check_octree<double>(c, leaf, 0.0);
    }
    check_octree<double>(c, 1, 0.1);
  }
}

// ---------- the order a batch is answered in ----------

// The length (L1, metres) of the path through the n queries in the given order (all of them in
// stored order when order is null).
double path_length_m(const double* xyz, std::size_t n, const std::uint32_t* order = nullptr) {
  double length_m = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double* a = xyz + 3 * (order ? order[i - 1] : i - 1);
    const double* b = xyz + 3 * (order ? order[i] : i);
    length_m += std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
  }
  return length_m;
}

// The Morton code of query i as morton_order computes it, from its cell on the grid.
std::uint64_t code_of(const std::array<std::uint32_t, 3>& cell) {
  return ours::spread_bits_3(cell[0]) | ours::spread_bits_3(cell[1]) << 1 | ours::spread_bits_3(cell[2]) << 2;
}

// Every vector path of the bucket scan gives each distance as nnb::sq_dist_m2 does, to the bit, and their
// minimum, for every block length (the paths differ in their tails) and awkward magnitudes.
TEST(OursScan, EveryVectorPathComputesDistancesAsSqDistM2) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  const std::array<double, 4> scales{1e-9, 1.0, 3e5, 1e150};
  for (const double scale : scales) {
    for (std::uint32_t m = 1; m <= ours::kScanBlock; ++m) {
      std::array<std::vector<double>, 3> xyz;
      for (auto& axis : xyz) {
        axis.resize(m);
        for (double& v : axis) v = scale * unit(rng);
      }
      const std::array<double, 3> q{scale * unit(rng), scale * unit(rng), scale * unit(rng)};
      std::vector<double> expected(m);
      double expected_min = std::numeric_limits<double>::infinity();
      for (std::uint32_t i = 0; i < m; ++i) {
        const std::array<double, 3> p{xyz[0][i], xyz[1][i], xyz[2][i]};
        expected[i] = nnb::sq_dist_m2(q.data(), p.data());
        expected_min = std::min(expected_min, expected[i]);
      }
      const auto check = [&](const char* path, auto scan) {
        std::vector<double> sq(m, -1.0);
        const double min = scan(xyz[0].data(), xyz[1].data(), xyz[2].data(), m, q, sq.data());
        EXPECT_EQ(min, expected_min) << path << ", m = " << m << ", scale " << scale;
        for (std::uint32_t i = 0; i < m; ++i) {
          ASSERT_EQ(std::memcmp(&sq[i], &expected[i], sizeof(double)), 0)
              << path << ", point " << i << " of " << m << ", scale " << scale;
        }
      };
      check("portable", ours::detail::block_sq_dists_portable<double>);
#if defined(OURS_WIDE_SIMD)
      if (ours::detail::kHasAvx2) check("avx2", ours::detail::block_sq_dists_avx2);
#endif
      check("dispatched", ours::block_sq_dists<double>);
    }
  }
}

#if defined(OURS_WIDE_SIMD)
// The scans take the AVX2 path exactly where the CPU has AVX2 and the OS saves its registers (CPUID leaves
// 1 and 7, XGETBV), asked here without the compiler's builtin. NNB_EXPECT_AVX2=0 or 1 also says which the
// CPU must be: ctest's run on an emulated CPU without AVX sets 0, so that its scans were the SSE2 path's.
TEST(OursScan, TheAvx2PathIsChosenByTheCpu) {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  bool avx2 = false;
  if (__get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_OSXSAVE) && (ecx & bit_AVX)) {
    unsigned xcr0_lo = 0, xcr0_hi = 0;
    __asm__("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
    const bool ymm_saved = (xcr0_lo & 6u) == 6u;  // the SSE and AVX state
    if (ymm_saved && __get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx)) avx2 = (ebx & bit_AVX2) != 0;
  }
  EXPECT_EQ(ours::detail::kHasAvx2, avx2);
  if (const char* expected = std::getenv("NNB_EXPECT_AVX2")) {
    EXPECT_EQ(avx2, std::string(expected) == "1") << "NNB_EXPECT_AVX2=" << expected;
  }
}
#endif

// Small and large batches: the same curve, each sorted in three passes.
TEST(QueryOrder, MortonOrderIsAPermutationAlongTheCurve) {
  for (const std::uint32_t n : {3000u, 40000u}) {
    const Cloud queries = queries_for(sphere(5000), 2.0, n);
    ours::QueryOrder order;
    ours::morton_order(queries.data(), n, order);
    std::vector<std::uint32_t> sorted = order.order;
    std::sort(sorted.begin(), sorted.end());
    for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i) << n << " queries";
    // Along the curve: each query's cell code is at least the previous one's, and equal codes keep the
    // caller's order.
    const Eigen::Vector3d lo = queries.rowwise().minCoeff();
    const double span_m = (queries.rowwise().maxCoeff() - lo).maxCoeff();
    auto code = [&](std::uint32_t i) {
      std::array<std::uint32_t, 3> cell{};
      for (int d = 0; d < 3; ++d) {
        cell[d] = std::min(1023u, static_cast<std::uint32_t>((queries(d, i) - lo[d]) * (1024.0 / span_m)));
      }
      return code_of(cell);
    };
    for (std::size_t s = 1; s < n; ++s) {
      const std::uint64_t a = code(order.order[s - 1]), b = code(order.order[s]);
      ASSERT_LE(a, b) << "at " << s << " of " << n;
      if (a == b) {
        ASSERT_LT(order.order[s - 1], order.order[s]);
      }
    }
    EXPECT_LT(path_length_m(queries.data(), n, order.order.data()), path_length_m(queries.data(), n) / 4)
        << "random queries in Morton order should make a far shorter path";
  }
}

// Sorted runs of distinct keys merge into one order, each part [first, last) on its own: one, two and
// five runs (some empty, one wholly above the others, equal codes told apart by their index).
TEST(QueryOrder, MergedRunsGiveEachPartOfTheSortedOrder) {
  std::mt19937_64 rng(11);
  for (const std::vector<std::size_t>& sizes : {std::vector<std::size_t>{9}, {0, 7}, {300, 41}, {5, 0, 64, 1, 200}}) {
    std::vector<std::vector<std::uint64_t>> runs;
    std::vector<std::uint64_t> all;
    std::uint32_t index = 0;
    for (std::size_t r = 0; r < sizes.size(); ++r) {
      std::vector<std::uint64_t> run;
      for (std::size_t i = 0; i < sizes[r]; ++i) {
        const std::uint64_t code = r == 1 ? 1000 + i : rng() % 50;  // run 1 lies above the others
        run.push_back(code << 32 | index++);
      }
      std::sort(run.begin(), run.end());
      all.insert(all.end(), run.begin(), run.end());
      runs.push_back(std::move(run));
    }
    std::sort(all.begin(), all.end());
    ours::KeyRuns spans;
    for (const auto& run : runs) spans.push_back({run.data(), run.data() + run.size()});
    const std::size_t n = all.size();
    for (const std::size_t parts : {std::size_t(1), std::size_t(2), std::size_t(3), n}) {
      std::vector<std::uint32_t> order(n, ~0u);
      for (std::size_t p = 0; p < parts; ++p) {
        ours::merge_key_runs(spans, n * p / parts, n * (p + 1) / parts, order.data());
      }
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(order[i], static_cast<std::uint32_t>(all[i]))
            << sizes.size() << " runs, " << parts << " parts, at " << i;
      }
    }
  }
}

TEST(QueryOrder, HostileCoordinatesStayOnTheGrid) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::vector<double>> batches = {
      {1e200, -1e200, 0, -1e308, 1e308, 5, 0, 0, 0},  // spans that overflow to infinity
      {nan, 1, 2, 3, nan, 4, 5, 6, nan},
      {inf, 0, 0, -inf, 0, 0, 1, 1, 1},
      {7, 7, 7, 7, 7, 7, 7, 7, 7},  // no extent at all
  };
  for (const auto& xyz : batches) {
    ours::QueryOrder order;
    ours::morton_order(xyz.data(), 3, order);
    std::vector<std::uint32_t> sorted = order.order;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, (std::vector<std::uint32_t>{0, 1, 2}));
  }
  ours::QueryOrder none;
  ours::morton_order(nullptr, 0, none);
  EXPECT_TRUE(none.order.empty());
}

// Batches large enough that "auto" judges the order after its first slice and "morton" sorts: every
// order gives brute force's rows, for random and for scan-ordered queries, plain and hinted.
TEST(OursAdapters, EveryQueryOrderGivesBruteForcesRows) {
  const Cloud model = with_duplicates(6000);
  const Cloud random = queries_for(model, 1.5, 5000);
  const Cloud scan = in_scan_order(random);
  auto brute = nnb::make_adapter("brute_force");
  brute->build(model);
  std::mt19937_64 rng(17);
  std::uniform_int_distribution<nnb::PointIndex> pick(0, 5999);
  std::vector<nnb::PointIndex> hints(5000);
  for (auto& h : hints) h = pick(rng) % 7 == 0 ? nnb::kNoHint : pick(rng);
  // Brute force's rows, per query order: ranged k=1 and k=4 at 0.3 m, k-NN k=3, ranged 1-NN at 0.5 m.
  std::vector<std::array<Neighbours, 4>> expected(2);
  const std::array<const Cloud*, 2> orders{&random, &scan};
  for (std::size_t o = 0; o < 2; ++o) {
    brute->ranged(*orders[o], 1, 0.3, expected[o][0]);
    brute->ranged(*orders[o], 4, 0.3, expected[o][1]);
    brute->knn(*orders[o], 3, expected[o][2]);
    brute->ranged(*orders[o], 1, 0.5, expected[o][3]);
  }
  for (const char* adapter : {"ours_kdtree", "ours_octree"}) {
    for (const char* scalar : {"double", "float"}) {
      for (const char* order : {"auto", "caller", "morton"}) {
        SCOPED_TRACE(std::string(adapter) + " " + scalar + " order=" + order);
        auto index = nnb::make_adapter(adapter, {{"scalar", scalar}, {"order", order}});
        index->build(model);
        Neighbours got;
        for (std::size_t o = 0; o < 2; ++o) {
          const Cloud& queries = *orders[o];
          SCOPED_TRACE(o == 0 ? "random order" : "scan order");
          index->ranged(queries, 1, 0.3, got);
          ASSERT_EQ("", exact_mismatch(model, queries, expected[o][0], got, true)) << "ranged k=1";
          index->ranged(queries, 4, 0.3, got);
          ASSERT_EQ("", exact_mismatch(model, queries, expected[o][1], got, true)) << "ranged k=4";
          index->knn(queries, 3, got);
          ASSERT_EQ("", exact_mismatch(model, queries, expected[o][2], got, true)) << "knn";
          index->ranged_hinted(queries, 0.5, hints, got);
          ASSERT_EQ("", exact_mismatch(model, queries, expected[o][3], got, true)) << "hinted";
        }
      }
    }
  }
}

// ---------- neighbour graph (hints=graph) ----------

// The graph of model, its rows made from brute force's k-NN.
ours::NeighbourGraph graph_of(const Cloud& model) {
  auto brute = nnb::make_adapter("brute_force");
  brute->build(model);
  Neighbours rows;
  brute->knn(model, ours::NeighbourGraph::kNeighboursAsked, rows);
  ours::NeighbourGraph graph;
  graph.reset(model.data(), static_cast<std::size_t>(model.cols()));
  for (std::size_t i = 0; i < rows.n_queries(); ++i) {
    graph.set(static_cast<std::uint32_t>(i), rows.indices.data() + rows.offsets[i], rows.sq_dists.data() + rows.offsets[i],
              rows.count(i));
  }
  return graph;
}

// Whatever the graph proves is brute force's answer: the same nearest point (a proof leaves no tie), the
// same distance to the bit, nothing where brute force finds nothing within the limit. Queries lie at every
// scale of distance from their hint, which is their source point or a random one; returns how many of
// those within `near_m` of their source were proven.
std::size_t check_graph_against_brute_force(const Cloud& model, double near_m) {
  const ours::NeighbourGraph graph = graph_of(model);
  auto brute = nnb::make_adapter("brute_force");
  brute->build(model);
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<Eigen::Index> pick(0, model.cols() - 1);
  std::normal_distribution<double> jitter(0, 1);
  const std::array<double, 5> scales_m{0.0, 0.1 * near_m, near_m, 10 * near_m, 1000 * near_m};
  const Eigen::Index n = 2000;
  Cloud queries(3, n);
  std::vector<std::uint32_t> hints(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index source = pick(rng);
    queries.col(i) = model.col(source) + scales_m[static_cast<std::size_t>(i) % scales_m.size()] *
                                              Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    hints[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(i % 7 == 6 ? pick(rng) : source);
  }
  std::size_t proven_near = 0;
  for (const double limit_m : {std::numeric_limits<double>::infinity(), near_m}) {
    Neighbours expected;
    if (std::isinf(limit_m)) brute->knn(queries, 1, expected);
    else brute->ranged(queries, 1, limit_m, expected);
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto q = static_cast<std::size_t>(i);
      std::uint32_t index = 0;
      double sq_m2 = 0;
      const auto answer = graph.nearest(queries.col(i).data(), hints[q], limit_m * limit_m, index, sq_m2);
      if (answer == ours::NeighbourGraph::Answer::unproven) continue;
      if (answer == ours::NeighbourGraph::Answer::none_within) {
        EXPECT_EQ(expected.count(q), 0u) << "query " << i << " has a neighbour within " << limit_m << " m";
        continue;
      }
      EXPECT_EQ(expected.count(q), 1u) << "query " << i;
      if (expected.count(q) != 1) continue;
      EXPECT_EQ(sq_m2, expected.sq_dists[expected.offsets[q]]) << "query " << i;
      EXPECT_EQ(index, expected.indices[expected.offsets[q]]) << "query " << i;
      const bool near = (queries.col(i) - model.col(hints[q])).norm() <= near_m;
      proven_near += std::isinf(limit_m) && near && i % 7 != 6;
    }
  }
  return proven_near;
}

TEST(NeighbourGraph, ProvesOnlyBruteForcesAnswers) {
  // Point spacing on the 3000-point sphere: about 0.04 m.
  EXPECT_GT(check_graph_against_brute_force(sphere(3000), 0.004), 500u) << "queries close to their hint are proven";
  check_graph_against_brute_force(with_duplicates(3000), 0.05);  // ties everywhere: left to the tree
  check_graph_against_brute_force(flat(3000), 0.004);
  check_graph_against_brute_force(collinear(3000), 0.001);
  check_graph_against_brute_force(shifted(sphere(3000), 1e-6, 0.3), 4e-9);
  check_graph_against_brute_force(shifted(sphere(3000), 1.0, 1e6), 0.004);
  check_graph_against_brute_force(sphere(5), 0.1);  // fewer points than a row asks for: the whole model
  check_graph_against_brute_force(sphere(1), 0.1);
}

// hints=graph answers exactly as the plain search, row for row (indices too), on one thread and on two
// (the graph is made by the first hinted batch, once, whichever thread gets there).
TEST(OursAdapters, GraphHintsGiveThePlainRows) {
  for (const Cloud& model : {sphere(6000), with_duplicates(6000)}) {
    const Cloud queries = in_scan_order(queries_for(model, 1.5, 5000));
    auto brute = nnb::make_adapter("brute_force");
    brute->build(model);
    Neighbours nearest;
    brute->knn(queries, 1, nearest);
    std::mt19937_64 rng(29);
    std::uniform_int_distribution<nnb::PointIndex> pick(0, static_cast<nnb::PointIndex>(model.cols() - 1));
    std::vector<nnb::PointIndex> hints(static_cast<std::size_t>(queries.cols()));
    for (std::size_t q = 0; q < hints.size(); ++q) {
      hints[q] = q % 5 == 0 ? nnb::kNoHint : q % 5 == 1 ? pick(rng) : nearest.indices[nearest.offsets[q]];
    }
    const std::array<double, 3> limits_m{0.01, 0.3, 5.0};
    std::array<Neighbours, 3> expected;
    for (std::size_t d = 0; d < limits_m.size(); ++d) brute->ranged(queries, 1, limits_m[d], expected[d]);
    for (const char* adapter : {"ours_kdtree", "ours_octree"}) {
      for (const char* scalar : {"double", "float"}) {
        for (const int threads : {1, 2}) {
          SCOPED_TRACE(std::string(adapter) + " " + scalar + " threads " + std::to_string(threads));
          auto index = nnb::make_adapter(adapter, {{"scalar", scalar}, {"hints", "graph"}});
          index->set_threads(threads);
          index->build(model);
          ASSERT_TRUE(index->info().uses_hints);
          for (std::size_t d = 0; d < limits_m.size(); ++d) {
            const double max_dist_m = limits_m[d];
            Neighbours plain, hinted;
            index->ranged(queries, 1, max_dist_m, plain);
            index->ranged_hinted(queries, max_dist_m, hints, hinted);
            ASSERT_EQ("", exact_mismatch(model, queries, expected[d], hinted, true)) << max_dist_m << " m";
            EXPECT_TRUE(hinted.offsets == plain.offsets && hinted.indices == plain.indices &&
                        hinted.sq_dists == plain.sq_dists)
                << "hints changed the rows at " << max_dist_m << " m";
          }
        }
      }
    }
  }
}

// ---------- memory ----------

#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
// How many of the whole pages inside [data, data + bytes) the kernel has not mapped yet (-1: unknown).
long unmapped_pages(const void* data, std::size_t bytes, std::size_t page) {
  const auto first = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t begin = (first + page - 1) / page * page;
  const std::uintptr_t end = (first + bytes) / page * page;
  std::vector<unsigned char> mapped((end - begin) / page);
  if (mincore(reinterpret_cast<void*>(begin), end - begin, mapped.data()) != 0) return -1;
  return static_cast<long>(std::count_if(mapped.begin(), mapped.end(), [](unsigned char m) { return !(m & 1); }));
}

TEST(OursMemory, LargeBlocksAreMappedInBeforeTheFirstWrite) {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  void* probe = mmap(nullptr, page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(probe, MAP_FAILED);
  const bool kernel_maps = madvise(probe, page, MADV_POPULATE_WRITE) == 0 && unmapped_pages(probe, page, page) == 0;
  munmap(probe, page);
  // A user-mode emulator (qemu-user) accepts the advice and maps nothing.
  if (!kernel_maps) {
    GTEST_SKIP() << "MADV_POPULATE_WRITE is refused or maps nothing here: blocks fault in on first write";
  }

  constexpr std::size_t kBytes = std::size_t{40} << 20;  // above any malloc's reuse threshold: fresh pages
  ours::DefaultInit<unsigned char> allocator;
  unsigned char* block = allocator.allocate(kBytes);
  EXPECT_EQ(unmapped_pages(block, kBytes, page), 0);
  allocator.deallocate(block, kBytes);
}
#endif

// ---------- adapters ----------

TEST(OursAdapters, IndexBytesCountNodesIndicesAndCopies) {
  const Cloud model = sphere(4000);
  auto kd = nnb::make_adapter("ours_kdtree", {{"scalar", "float"}, {"bucket_size", "8"}});
  kd->build(model);
  ours::KdTree<float> tree;
  tree.build(model.data(), 4000, 8);
  EXPECT_EQ(kd->index_bytes(), tree.nodes().size() * 8 + 4000 * 4 + 4000 * 12);
  auto oc = nnb::make_adapter("ours_octree", {{"scalar", "double"}, {"max_points_per_leaf", "8"}});
  oc->build(model);
  ours::Octree<double> octree;
  octree.build(model.data(), 4000, 8, 0.0);
  EXPECT_EQ(oc->index_bytes(), octree.nodes().size() * 8 + 4000 * 4 + 4000 * 24);
}

TEST(OursAdapters, BadParametersAreRefused) {
  EXPECT_THROW(nnb::make_adapter("ours_kdtree", {{"bucket_size", "0"}}), nnb::InputError);
  EXPECT_THROW(nnb::make_adapter("ours_kdtree", {{"scalar", "half"}}), nnb::InputError);
  EXPECT_THROW(nnb::make_adapter("ours_kdtree", {{"leaf", "3"}}), nnb::InputError);
  EXPECT_THROW(nnb::make_adapter("ours_octree", {{"max_points_per_leaf", "x"}}), nnb::InputError);
  EXPECT_THROW(nnb::make_adapter("ours_octree", {{"min_cell_size_m", "-1"}}), nnb::InputError);
  EXPECT_THROW(nnb::make_adapter("ours_kdtree", {{"order", "hilbert"}}), nnb::InputError);
}

}  // namespace
