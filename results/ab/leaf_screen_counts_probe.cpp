// Probe (not kept; counts, no timing): how many of a leaf's points a scan-ordered 1-NN query would still have to measure if it
// screened them by an earlier query's distances. For a run of queries in one leaf, r is the last query whose
// leaf was scanned in full; by the triangle inequality |q-p| >= |r-p| - |q-r|, and the answer lies within
// min(|r-p_r| + |q-r|, limit), so only points with |r-p| <= that + |q-r| are candidates. A query whose
// candidates exceed a cap scans in full and becomes the new r. Queries in file order; leaves found by descent.
// Built from the project root after a Release build:
//   g++ -std=c++17 -O3 -DNDEBUG -ffp-contract=off -Iours/include -Icore/include -Idatasets/include \
//     -I/usr/include/eigen3 results/ab/leaf_screen_counts_probe.cpp build/release/datasets/libnnb_datasets.a \
//     -lcrypto -o /tmp/leaf_screen_counts && /tmp/leaf_screen_counts
#include "ours/kdtree.hpp"
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/manifest.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  const double dists[] = {0.02, 0.1, 1.0};
  const int caps[] = {8, 16};
  nnb::datasets::DataOptions options;
  std::printf("%-26s %6s %4s | %8s %8s %8s | %9s %9s %9s\n", "pair", "d [m]", "cap", "sameleaf", "screened", "cand/scr",
              "full/q", "measured/q", "compared/q");
  for (const auto& pair : nnb::datasets::real_pairs()) {
    if (pair.kind != "files") continue;
    using nnb::datasets::Role;
    const nnb::Cloud model = nnb::datasets::resolve_cloud(pair.name, Role::model, options).points;
    const nnb::Cloud q = nnb::datasets::resolve_cloud(pair.name, Role::query, options).points;
    ours::KdTree<double> tree;
    tree.build(model.data(), model.cols(), 64);
    const auto& nodes = tree.nodes();
    auto leaf_of = [&](const double* p) {
      std::uint32_t i = 0;
      while (!nodes[i].is_leaf()) {
        const unsigned d = nodes[i].dim();
        i = p[d] > tree.plane(d, nodes[i].cut) ? nodes[i].right_or_size() : i + 1;
      }
      return i;
    };
    const std::size_t n = q.cols();
    for (double limit : dists) {
      for (int cap : caps) {
        std::size_t same = 0, screened = 0, cand = 0, measured = 0, full = 0, compared = 0;
        std::uint32_t prev_leaf = ~0u;
        std::vector<double> d_r;  // r's distances to the leaf's points
        double r[3] = {0, 0, 0}, best_r = 0;
        for (std::size_t j = 0; j < n; ++j) {
          const double* p = q.data() + 3 * j;
          const std::uint32_t leaf = leaf_of(p);
          const auto& L = nodes[leaf];
          const std::uint32_t b = L.bucket, m = L.right_or_size();
          full += m;
          auto full_scan = [&] {
            d_r.resize(m);
            best_r = INFINITY;
            for (std::uint32_t k = 0; k < m; ++k) {
              double s = 0;
              for (int d = 0; d < 3; ++d) s += (p[d] - tree.coord(b + k, d)) * (p[d] - tree.coord(b + k, d));
              d_r[k] = std::sqrt(s);
              best_r = std::min(best_r, d_r[k]);
            }
            for (int d = 0; d < 3; ++d) r[d] = p[d];
            measured += m;
          };
          if (leaf != prev_leaf) {
            full_scan();
          } else {
            ++same;
            const double delta = std::sqrt((p[0] - r[0]) * (p[0] - r[0]) + (p[1] - r[1]) * (p[1] - r[1]) +
                                           (p[2] - r[2]) * (p[2] - r[2]));
            const double reach = std::min(best_r + delta, limit) + delta;
            std::size_t c = 0;
            for (std::uint32_t k = 0; k < m; ++k) c += d_r[k] <= reach ? 1 : 0;
            if (int(c) <= cap) {
              ++screened;
              compared += m;
              cand += c;
              measured += c;
            } else {
              full_scan();
            }
          }
          prev_leaf = leaf;
        }
        std::printf("%-26s %6.2f %4d | %7.1f%% %7.1f%% %8.2f | %9.2f %9.2f %9.2f\n", pair.name.c_str(), limit,
                    cap, 100.0 * same / n, 100.0 * screened / n, screened ? double(cand) / screened : 0.0,
                    double(full) / n, double(measured) / n, double(compared) / n);
      }
    }
  }
  (void)argc;
  (void)argv;
}
