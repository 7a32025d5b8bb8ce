// Micro-benchmarks: build time, and ranged 1-NN over the paper's Figure 3 pair (model: hollow sphere,
// queries: hollow cube, 60,000 points each) at several max distances, for our structures and the
// libraries they are measured against, all through the same SearchIndex API, single-threaded, one run.
// Compare adapters by the ratio of their items_per_second within one run; bytes_per_point is the index
// memory (nodes, indices, copies) per model point.
#include "nnb/datasets/synthetic.hpp"
#include "nnb/registry.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace {

struct Subject {
  std::string label;  // adapter name plus any non-default parameters
  std::string adapter;
  nnb::Params params;
};

const nnb::Cloud& model_cloud() {
  static const nnb::Cloud cloud = nnb::datasets::make_shape(nnb::datasets::Shape::hollow_sphere, 60000, 1);
  return cloud;
}

const nnb::Cloud& query_cloud() {
  static const nnb::Cloud cloud = nnb::datasets::make_shape(nnb::datasets::Shape::hollow_cube, 60000, 1);
  return cloud;
}

void bench_build(benchmark::State& state, const Subject& s) {
  const nnb::Cloud& model = model_cloud();
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto index = nnb::make_adapter(s.adapter, s.params);
    index->build(model);
    bytes = index->index_bytes();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes_per_point"] = double(bytes) / double(model.cols());
  state.SetItemsProcessed(state.iterations() * model.cols());
}

void bench_ranged(benchmark::State& state, const Subject& s, double max_dist_m) {
  const nnb::Cloud& model = model_cloud();
  const nnb::Cloud& queries = query_cloud();
  auto index = nnb::make_adapter(s.adapter, s.params);
  index->build(model);
  nnb::Neighbours out;
  for (auto _ : state) {
    index->ranged(queries, 1, max_dist_m, out);
    benchmark::DoNotOptimize(out.indices.data());
  }
  state.counters["found"] = double(out.queries_with_neighbours());
  state.counters["bytes_per_point"] = double(index->index_bytes()) / double(model.cols());
  state.SetItemsProcessed(state.iterations() * queries.cols());
}

std::vector<Subject> subjects() {
  std::vector<Subject> all;
  const std::vector<std::string> built = nnb::adapter_names();
  auto have = [&](const std::string& name) { return std::find(built.begin(), built.end(), name) != built.end(); };
  std::vector<std::string> skipped;
  for (const char* name : {"ours_kdtree", "ours_octree", "nanoflann_kdtree", "flann_kdtree", "pcl_octree", "ann_kdtree"}) {
    if (have(name)) all.push_back({name, name, {}});
    else skipped.push_back(name);
  }
  // Our variants, to choose the defaults: the other scalar, and other bucket and leaf sizes.
  if (have("ours_kdtree")) {
    for (const char* scalar : {"float", "double"}) {
      for (const char* bucket : {"5", "8", "16", "32"}) {
        all.push_back({std::string("ours_kdtree[") + scalar + ",b" + bucket + "]", "ours_kdtree",
                       {{"scalar", scalar}, {"bucket_size", bucket}}});
      }
    }
  }
  if (have("ours_octree")) {
    for (const char* scalar : {"float", "double"}) {
      for (const char* leaf : {"8", "16", "32", "64"}) {
        all.push_back({std::string("ours_octree[") + scalar + ",p" + leaf + "]", "ours_octree",
                       {{"scalar", scalar}, {"max_points_per_leaf", leaf}}});
      }
    }
  }
  std::cerr << "micro_nns: skipped (not built in):";
  for (const auto& name : skipped) std::cerr << ' ' << name;
  std::cerr << (skipped.empty() ? " none\n" : "\n");
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  for (const Subject& s : subjects()) {
    benchmark::RegisterBenchmark(("Build/" + s.label).c_str(), [s](benchmark::State& st) { bench_build(st, s); })
        ->Unit(benchmark::kMillisecond);
    for (const double max_dist_m : {0.02, 0.1, 0.3, 1.0}) {
      char dist[16];
      std::snprintf(dist, sizeof dist, "%.2f", max_dist_m);
      benchmark::RegisterBenchmark(("Ranged1NN/" + s.label + "/" + dist).c_str(),
                                   [s, max_dist_m](benchmark::State& st) { bench_ranged(st, s, max_dist_m); })
          ->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
