// Micro-benchmarks: build time, and ranged 1-NN over all queries of two pairs, for our structures and
// the libraries they are measured against, all through the same SearchIndex API, single-threaded:
//   fig3: the paper's Figure 3 pair (model: hollow sphere, queries: hollow cube, 60,000 points each)
//         at max distances 0.02, 0.1, 0.3, 1.0 m;
//   sick: the SICK office pair (office-sick-3dtk, query in the model frame) at the same distances;
//   sick_shuffled: the same, queries in a fixed random order, for the main subjects only: what the scan
//         order is worth (our k-d tree reuses the previous query's descent; the octree its path).
// At the end it prints, from this run's own timings (the fastest repetition of each), the ratios our
// structures aim at (k-d tree >= 1.5x nanoflann, 1x at 1 m; octree >= 2x PCL's; octree time <= 1.3x the
// k-d tree's) marked PASS/MISS, and the index memory per model point. The table goes to stdout with the
// console output; use --benchmark_out=FILE --benchmark_out_format=json for the raw results.
#include "cli_common.hpp"
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/synthetic.hpp"
#include "nnb/registry.hpp"
#include "ours/kdtree.hpp"
#include "ours/octree.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <optional>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

struct Subject {
  std::string label;  // adapter name plus any non-default parameters
  std::string adapter;
  nnb::Params params;
};

struct PairSpec {
  std::string name;                // as in benchmark names
  std::vector<double> max_dist_m;  // the distances measured on it
  bool targets;                    // the target ratios apply (else the ratios are for information)
};

// --data-dir as given (empty: the default lookup).
std::string& data_dir() {
  static std::string dir;
  return dir;
}

nnb::datasets::DataOptions sick_options() {
  nnb::datasets::DataOptions options;
  options.data_dir = data_dir();
  return options;
}

const std::vector<PairSpec>& pairs() {
  static const std::vector<PairSpec> all{{"fig3", {0.02, 0.1, 0.3, 1.0}, true},
                                         {"sick", {0.02, 0.1, 0.3, 1.0}, true},
                                         {"sick_shuffled", {0.02, 0.1, 0.3, 1.0}, false}};
  return all;
}

struct Clouds {
  nnb::Cloud model, queries;
  std::string error;  // why the pair could not be loaded
};

const Clouds& clouds(const std::string& pair) {
  static std::map<std::string, Clouds> loaded;
  auto it = loaded.find(pair);
  if (it != loaded.end()) return it->second;
  Clouds c;
  if (pair == "fig3") {
    c.model = nnb::datasets::make_shape(nnb::datasets::Shape::hollow_sphere, 60000, 1);
    c.queries = nnb::datasets::make_shape(nnb::datasets::Shape::hollow_cube, 60000, 1);
  } else if (pair == "sick_shuffled") {
    c = clouds("sick");
    if (c.error.empty()) {
      std::vector<Eigen::Index> order(static_cast<std::size_t>(c.queries.cols()));
      std::iota(order.begin(), order.end(), Eigen::Index(0));
      std::shuffle(order.begin(), order.end(), std::mt19937_64(42));
      const nnb::Cloud scan = c.queries;
      for (std::size_t i = 0; i < order.size(); ++i) c.queries.col(Eigen::Index(i)) = scan.col(order[i]);
    }
  } else {
    try {
      using nnb::datasets::Role;
      c.model = nnb::datasets::resolve_cloud("office-sick-3dtk", Role::model, sick_options()).points;
      c.queries = nnb::datasets::resolve_cloud("office-sick-3dtk", Role::query, sick_options()).points;
    } catch (const std::exception& e) {
      c.error = e.what();
    }
  }
  return loaded.emplace(pair, std::move(c)).first->second;
}

void bench_build(benchmark::State& state, const Subject& s) {
  const nnb::Cloud& model = clouds("fig3").model;
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

void bench_ranged(benchmark::State& state, const Subject& s, const std::string& pair, double max_dist_m) {
  const Clouds& c = clouds(pair);
  if (!c.error.empty()) {
    state.SkipWithError(c.error.c_str());
    for (auto _ : state) {
    }
    return;
  }
  auto index = nnb::make_adapter(s.adapter, s.params);
  index->build(c.model);
  nnb::Neighbours out;
  for (auto _ : state) {
    index->ranged(c.queries, 1, max_dist_m, out);
    benchmark::DoNotOptimize(out.indices.data());
  }
  state.counters["found"] = double(out.queries_with_neighbours());
  state.counters["bytes_per_point"] = double(index->index_bytes()) / double(c.model.cols());
  state.SetItemsProcessed(state.iterations() * c.queries.cols());
}

std::string distance_text(double max_dist_m) {
  char text[16];
  std::snprintf(text, sizeof text, "%.2f", max_dist_m);
  return text;
}

std::string ranged_name(const std::string& pair, const std::string& label, double max_dist_m) {
  return "Ranged1NN/" + pair + "/" + label + "/" + distance_text(max_dist_m);
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
    all.push_back({"ours_kdtree[float]", "ours_kdtree", {{"scalar", "float"}}});
    for (const char* bucket : {"8", "16", "32", "64", "96"}) {
      all.push_back({std::string("ours_kdtree[b") + bucket + "]", "ours_kdtree", {{"bucket_size", bucket}}});
    }
  }
  if (have("ours_octree")) {
    all.push_back({"ours_octree[float]", "ours_octree", {{"scalar", "float"}}});
    for (const char* leaf : {"16", "32", "48", "64", "96", "128"}) {
      all.push_back({std::string("ours_octree[p") + leaf + "]", "ours_octree", {{"max_points_per_leaf", leaf}}});
    }
  }
  std::cerr << "micro_nns: skipped (not built in):";
  for (const auto& name : skipped) std::cerr << ' ' << name;
  std::cerr << (skipped.empty() ? " none\n" : "\n");
  return all;
}

// The console reporter, also keeping the fastest CPU time per iteration (ms) of every benchmark.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  // Colours only on a terminal (this reporter replaces the one --benchmark_color would configure).
  RatioReporter() : ConsoleReporter(isatty(fileno(stdout)) ? OO_Defaults : OO_Tabular) {}

  void ReportRuns(const std::vector<Run>& reports) override {
    ConsoleReporter::ReportRuns(reports);
    for (const Run& run : reports) {
      if (run.run_type != Run::RT_Iteration || run.error_occurred) continue;
      const std::string name = run.benchmark_name();
      const double ms = run.GetAdjustedCPUTime();
      auto it = best_ms_.find(name);
      if (it == best_ms_.end() || ms < it->second) best_ms_[name] = ms;
    }
  }

  // Returns the fastest CPU time (ms) of that benchmark, or a negative number when it did not run.
  double ms(const std::string& name) const {
    auto it = best_ms_.find(name);
    return it == best_ms_.end() ? -1.0 : it->second;
  }

 private:
  std::map<std::string, double> best_ms_;
};

// One line per distance: ours_kdtree vs nanoflann (>= 1.5x up to the second largest distance, >= 1x
// at the largest), ours_octree vs pcl_octree (>= 2x), ours_octree time / ours_kdtree time (<= 1.3).
void print_ratios(const RatioReporter& r) {
  std::printf("\nRatios from this run (CPU time, fastest repetition; speed-up = their time / ours):\n");
  std::printf("%-13s %6s | %-22s | %-22s | %-22s\n", "pair", "d [m]", "kdtree vs nanoflann", "octree vs pcl_octree",
              "octree/kdtree time");
  auto cell = [](double num, double den, double target, bool at_least, bool judged) {
    char text[32];
    if (num <= 0 || den <= 0) return std::string("n/a (not run)");
    const double ratio = num / den;
    const bool pass = at_least ? ratio >= target : ratio <= target;
    std::snprintf(text, sizeof text, "%5.2f%s %s %.1f %s", ratio, at_least ? "x" : " ", at_least ? ">=" : "<=", target,
                  !judged ? "info" : pass ? "PASS" : "MISS");
    return std::string(text);
  };
  for (const PairSpec& pair : pairs()) {
    for (std::size_t i = 0; i < pair.max_dist_m.size(); ++i) {
      const double d = pair.max_dist_m[i];
      const double kd = r.ms(ranged_name(pair.name, "ours_kdtree", d));
      const double oc = r.ms(ranged_name(pair.name, "ours_octree", d));
      const double nano = r.ms(ranged_name(pair.name, "nanoflann_kdtree", d));
      const double pcl = r.ms(ranged_name(pair.name, "pcl_octree", d));
      const double kd_target = i + 1 < pair.max_dist_m.size() ? 1.5 : 1.0;
      std::printf("%-13s %6.2f | %-22s | %-22s | %-22s\n", pair.name.c_str(), d,
                  cell(nano, kd, kd_target, true, pair.targets).c_str(), cell(pcl, oc, 2.0, true, pair.targets).c_str(),
                  cell(oc, kd, 1.3, false, pair.targets).c_str());
    }
  }
}

// Index memory per model point on the Figure 3 model, by part for ours, as reported by the adapter
// for the others (what each counts is in its index_bytes()).
void print_memory() {
  const nnb::Cloud& model = clouds("fig3").model;
  const double n = double(model.cols());
  std::printf("\nIndex memory per model point (fig3 model, %d points):\n", int(model.cols()));
  const std::vector<std::string> built = nnb::adapter_names();
  if (std::find(built.begin(), built.end(), "ours_kdtree") == built.end()) return;  // ours not built in
  // The adapters' defaults (double scalar), built directly to see the parts.
  const int bucket = nnb::make_adapter("ours_kdtree", {})->info().bucket->value;
  const int leaf = nnb::make_adapter("ours_octree", {})->info().bucket->value;
  ours::KdTree<double> kd;
  kd.build(model.data(), model.cols(), bucket);
  std::printf("  ours_kdtree (b%d): nodes %.2f B (%zu B each) + bucket indices %.2f B = %.2f B excl. points; "
              "+ point copies %.2f B\n",
              bucket, kd.node_bytes() / n, sizeof(ours::KdTree<double>::Node), kd.index_bytes() / n,
              (kd.node_bytes() + kd.index_bytes()) / n, kd.point_copy_bytes() / n);
  ours::Octree<double> oc;
  oc.build(model.data(), model.cols(), leaf, 0.0);
  std::printf("  ours_octree (p%d): nodes %.2f B + leaf indices %.2f B = %.2f B excl. points; + point copies %.2f B\n",
              leaf, oc.node_bytes() / n, oc.index_bytes() / n, (oc.node_bytes() + oc.index_bytes()) / n,
              oc.point_copy_bytes() / n);
}

// The libraries' index memory per point, as each adapter counts it.
void print_library_memory(const std::vector<Subject>& all) {
  const nnb::Cloud& model = clouds("fig3").model;
  const double n = double(model.cols());
  for (const Subject& s : all) {
    if (s.label != s.adapter || s.adapter.rfind("ours_", 0) == 0) continue;
    auto index = nnb::make_adapter(s.adapter, s.params);
    index->build(model);
    std::printf("  %-22s %.2f B as its adapter counts it\n", (s.adapter + ":").c_str(), index->index_bytes() / n);
  }
}

// Takes out the options micro_nns shares with the other programs (--version, --data-dir) before Google
// Benchmark reads its own; returns the exit code when the program should stop now.
std::optional<int> take_shared_options(int& argc, char** argv) {
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--version") {
      std::cout << nnb::cli::version_line("micro_nns") << "\n";
      return 0;
    }
    if (arg == "--help" || arg == "-h") {
      std::cout << "micro_nns: build and ranged 1-NN of ours against the libraries (times in ms)\n"
                << "  --version          " << "print the version, git commit and build type, and exit\n"
                << "  --data-dir DIR     " << nnb::cli::kDataDirHelp << "\n"
                << "and Google Benchmark's options:\n";
      argv[kept++] = argv[i];
    } else if (arg == "--data-dir" || arg.rfind("--data-dir=", 0) == 0) {
      if (arg == "--data-dir" && i + 1 == argc) {
        std::cerr << "micro_nns: error: --data-dir needs a folder (see --help)\n";
        return 2;
      }
      data_dir() = arg == "--data-dir" ? argv[++i] : arg.substr(std::strlen("--data-dir="));
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  if (const auto code = take_shared_options(argc, argv)) return *code;
  benchmark::Initialize(&argc, argv);
  if (argc > 1) {
    std::cerr << "micro_nns: error: unknown option '" << argv[1] << "' (see --help)\n";
    return 2;
  }
  const std::vector<Subject> all = subjects();
  for (const Subject& s : all) {
    benchmark::RegisterBenchmark(("Build/" + s.label).c_str(), [s](benchmark::State& st) { bench_build(st, s); })
        ->Unit(benchmark::kMillisecond);
    for (const PairSpec& pair : pairs()) {
      if (!pair.targets && s.label != s.adapter) continue;  // variants only where the targets are
      for (const double max_dist_m : pair.max_dist_m) {
        const std::string p = pair.name;
        benchmark::RegisterBenchmark(ranged_name(p, s.label, max_dist_m).c_str(),
                                     [s, p, max_dist_m](benchmark::State& st) { bench_ranged(st, s, p, max_dist_m); })
            ->Unit(benchmark::kMillisecond);
      }
    }
  }
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_ratios(reporter);
  print_memory();
  print_library_memory(all);
  benchmark::Shutdown();
  return 0;
}
