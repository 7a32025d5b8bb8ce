// A/B probe, not part of the benchmark (prefetch_probe.sh builds it twice): hnswlib 0.6.2 as Debian ships it,
// with its SSE prefetches (the default) and with NO_MANUAL_VECTORIZATION (none), on one scan: the graph built
// over its points (M 16, ef_construction 200, inserted in order), then 1-NN (ef 10) of every point moved by
// normal noise of s.d. 0.02 a coordinate, in the scan's units (3DTK's SICK scans are in centimetres: 0.2 mm).
// Prints the build and search times and the sum of the squared distances found.
#include <hnswlib/hnswlib.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <vector>

int main(int, char** argv) {
  std::vector<float> xyz;
  std::ifstream in(argv[1]);
  for (float v; in >> v;) xyz.push_back(v);
  const std::size_t n = xyz.size() / 3;
  hnswlib::L2Space space(3);
  const auto t0 = std::chrono::steady_clock::now();
  hnswlib::HierarchicalNSW<float> graph(&space, n, 16, 200);
  for (std::size_t i = 0; i < n; ++i) graph.addPoint(&xyz[3 * i], i);
  graph.setEf(10);
  const auto t1 = std::chrono::steady_clock::now();
  std::mt19937_64 rng(1);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const float q[3] = {xyz[3 * i] + noise(rng), xyz[3 * i + 1] + noise(rng), xyz[3 * i + 2] + noise(rng)};
    sum += graph.searchKnn(q, 1).top().first;
  }
  const auto t2 = std::chrono::steady_clock::now();
  const double build_s = std::chrono::duration<double>(t1 - t0).count();
  const double search_s = std::chrono::duration<double>(t2 - t1).count();
  std::printf("%zu points, build %.3f s, search %.3f s (%.2f us a query), sum of squared distances %.9g\n", n,
              build_s, search_s, 1e6 * search_s / n, sum);
}
