// A ranged search (the 3 nearest within 0.15 m) on a random cloud, through the registry's ours_kdtree
// and through our header-only k-d tree directly; both must equal the brute_force adapter. Exit 1 if not.
#include <nnb/registry.hpp>
#include <ours/kdtree.hpp>

#include <cstdio>
#include <random>

int main() {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> coord(-1.0, 1.0);
  nnb::Cloud model(3, 3000), queries(3, 300);
  const auto point = [&] { return Eigen::Vector3d(coord(rng), coord(rng), coord(rng)); };
  for (Eigen::Index i = 0; i < model.cols(); ++i) model.col(i) = point();
  for (Eigen::Index i = 0; i < queries.cols(); ++i) queries.col(i) = 1.2 * point();
  const int k = 3;
  const double max_dist_m = 0.15;

  nnb::Neighbours expected, got;
  auto reference = nnb::make_adapter("brute_force");
  reference->build(model);
  reference->ranged(queries, k, max_dist_m, expected);
  auto index = nnb::make_adapter("ours_kdtree");
  index->build(model);
  index->ranged(queries, k, max_dist_m, got);
  bool ok = got.offsets == expected.offsets && got.indices == expected.indices && got.sq_dists == expected.sq_dists;

  ours::KdTree<double> tree;
  tree.build(model.data(), static_cast<std::size_t>(model.cols()), 16);
  ours::KdTree<double>::Buffers buffers;
  for (Eigen::Index q = 0; q < queries.cols(); ++q) {
    tree.knn(queries.col(q).data(), k, max_dist_m * max_dist_m, buffers);
    const auto first = expected.offsets[static_cast<std::size_t>(q)];
    ok = ok && buffers.best.size() == expected.count(static_cast<std::size_t>(q));
    for (std::size_t i = 0; ok && i < buffers.best.size(); ++i) {
      ok = buffers.best[i].index == expected.indices[first + i] &&
           buffers.best[i].sq_dist == expected.sq_dists[first + i];
    }
  }
  std::printf("%zu neighbours for %zu queries: %s\n", expected.total(), expected.n_queries(), ok ? "ok" : "MISMATCH");
  return ok && expected.total() > 0 ? 0 : 1;
}
