// Where an ALGLIB k-d tree query's time goes: its thread-safe 1-NN call and an (almost always empty) 1 mm
// radius call, timed per query over 100,000 uniform queries in a 10 m cube, on trees of 1 to 100,000 uniform
// points. A tree of one point leaves only what a call costs before any walk (the C++ wrapper's error state,
// the buffer's checks, the distance to the root box); the rest grows with the depth of the walk.
#include <alglibmisc.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

int main() {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> in_cube_m(0, 10);
  const int n_queries = 100000;
  std::vector<double> queries(3 * n_queries);
  for (double& v : queries) v = in_cube_m(rng);
  for (const int n_points : {1, 10, 100, 1000, 10000, 100000}) {
    alglib::real_2d_array xy;
    xy.setlength(n_points, 3);
    for (int i = 0; i < n_points; ++i)
      for (int d = 0; d < 3; ++d) xy[i][d] = in_cube_m(rng);
    alglib::kdtree tree;
    alglib::kdtreebuild(xy, n_points, 3, 0, 2, tree);
    alglib::kdtreerequestbuffer buffer;
    alglib::kdtreecreaterequestbuffer(tree, buffer);
    alglib::real_1d_array x;
    x.setlength(3);
    for (const bool knn : {true, false}) {
      double best_ns = 1e30;
      long found = 0;
      for (int repetition = 0; repetition < 5; ++repetition) {
        const auto start = std::chrono::steady_clock::now();
        found = 0;
        for (int q = 0; q < n_queries; ++q) {
          for (int d = 0; d < 3; ++d) x[d] = queries[3 * q + d];
          found += knn ? alglib::kdtreetsqueryknn(tree, buffer, x, 1, true)
                       : alglib::kdtreetsqueryrnnu(tree, buffer, x, 0.001, true);
        }
        const std::chrono::duration<double, std::nano> took = std::chrono::steady_clock::now() - start;
        best_ns = std::min(best_ns, took.count() / n_queries);
      }
      std::printf("%7d points  %-22s %6.0f ns a query (fastest of 5; %ld found)\n", n_points,
                  knn ? "1-NN" : "radius 1 mm", best_ns, found);
    }
  }
}
