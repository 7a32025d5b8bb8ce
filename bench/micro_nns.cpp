// Micro-benchmarks of our structures against the best packaged tree, through the same SearchIndex API,
// single-threaded unless named threads:<n>, and the targets they are held to (printed at the end with
// PASS/MISS, from this run's own timings: the fastest repetition of each benchmark, CPU time, or wall time
// for threads):
//   Ranged1NN/<pair>/<subject>/<max dist>: ranged 1-NN over all queries of a pair. Pairs: fig3 (the
//       paper's Figure 3: hollow cube queries against a hollow sphere, 60,000 points each) and every real
//       pair of the manifest (query at its reference pose), in file order and shuffled (<pair>_shuffled).
//   Build/<pair>/<subject>: building the index over a pair's model (and the 16M-point simulated city scan).
//   Ranged1NN/<pair>/<subject>/<max dist>/threads:<n>: the same on n threads (2 to --threads, default 2),
//       wall time, on fig3 and the SICK pair in file order, for ours and the anchors.
//   Ranged2NN/<pair>/<subject>/0.10: the two nearest within 0.1 m (what ICP's tracked neighbours ask),
//       ours and the anchors on every pair in file order; for information, no target.
//   IcpStep/<pair>: what ICP does between two searches (the fit from the pairs of a 0.5 m ranged 1-NN
//       search, then moving every query point), per correspondence.
//   Icp/<pair>/<subject>: a whole ICP run (searches and steps, construction excluded) on every real pair, from
//       the pair's initial pose with run_icp's icp_real settings for it, ours and the anchors at their defaults.
// Targets: ours (the faster of our k-d tree and octree) at least 2x the faster nanoflann (Debian's and,
// when built in, the newest) at every distance on every pair in both orders; under 100 ns a query at
// <= 0.1 m on fig3 and the SICK pair; ICP with ours at least 2.5x faster than with the faster nanoflann on
// every real pair; an ICP step under 10 ns a correspondence; building at least 2x
// faster than the faster nanoflann; ours at least 1.8x faster on 2 threads than on one (wall time). Use
// --benchmark_out=FILE --benchmark_out_format=json for the raw results (written whole at the end, through a
// temporary) and --benchmark_filter to run part of it (what did not run prints as "not run"). The reference
// run adds --benchmark_repetitions=7 --benchmark_min_time=0.2 --benchmark_enable_random_interleaving=true:
// a ratio's two sides then sample the same spells of a shared machine.
#include "cli_common.hpp"
#include "files.hpp"
#include "icp.hpp"
#include "icp_experiment.hpp"
#include "machine.hpp"
#include "nnb/datasets/catalog.hpp"
#include "nnb/registry.hpp"
#include "ours/kdtree.hpp"
#include "ours/octree.hpp"
#include "timed_batches.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <unistd.h>

namespace {

struct Subject {
  std::string label;  // adapter name plus any non-default parameters
  std::string adapter;
  nnb::Params params;
};

struct PairSpec {
  std::string name;     // as in benchmark names
  std::string dataset;  // the pair in the catalog; empty for fig3
  bool shuffled;        // queries in a fixed random order instead of the file's
  bool fast_target;     // the under-100-ns target applies
};

const std::vector<double> kDistancesM{0.02, 0.1, 0.3, 1.0};
constexpr double kThreadTarget = 1.8;  // wall-time speed-up of ours from 1 to 2 threads
constexpr double kIcpStepDistM = 0.5;
constexpr double kIcpTarget = 2.5;  // ICP time with the faster nanoflann over ICP time with the faster of ours
const char* const kIcpExperiment = "icp_real";  // whose per-pair settings the ICP benchmarks run
const char* const kCityScan = "city-tls-16m";
// Ours, and the anchors they are measured against.
const std::vector<std::string> kOurs{"ours_kdtree", "ours_octree"};
const std::vector<std::string> kAnchors{"nanoflann_kdtree", "nanoflann_latest"};

// --data-dir as given (empty: the default lookup).
// The most threads the threaded benchmarks run on (--threads).
int& max_threads() {
  static int threads = 2;
  return threads;
}

std::string& data_dir() {
  static std::string dir;
  return dir;
}

// --benchmark_out as given, and the argument Google Benchmark gets instead (empty: none given): the file's
// temporary, moved in place once the run ends, so that an interrupted run leaves the last whole file.
std::string& out_path() {
  static std::string path;
  return path;
}

std::string& out_argument() {
  static std::string argument;
  return argument;
}

nnb::datasets::DataOptions data_options() {
  nnb::datasets::DataOptions options;
  options.data_dir = data_dir();
  return options;
}

const std::vector<PairSpec>& pairs() {
  static const std::vector<PairSpec> all = [] {
    std::vector<PairSpec> out{{"fig3", "", false, true}};
    for (const auto& pair : nnb::datasets::real_pairs()) {
      const bool sick = pair.name == "office-sick-3dtk";
      out.push_back({pair.name, pair.name, false, sick});
      out.push_back({pair.name + "_shuffled", pair.name, true, sick});
    }
    return out;
  }();
  return all;
}

struct Clouds {
  nnb::Cloud model, queries;
  std::string error;  // why the pair could not be loaded
};

Clouds load(const PairSpec& spec) {
  Clouds c;
  if (spec.dataset.empty()) {
    nnb::bench::Figure3Pair fig3 = nnb::bench::figure3_pair();
    c.model = std::move(fig3.model);
    c.queries = std::move(fig3.queries);
    return c;
  }
  try {
    using nnb::datasets::Role;
    c.model = nnb::datasets::resolve_cloud(spec.dataset, Role::model, data_options()).points;
    c.queries = nnb::datasets::resolve_cloud(spec.dataset, Role::query, data_options()).points;
    if (spec.shuffled) c.queries = nnb::bench::shuffled_scan(c.queries);
  } catch (const std::exception& e) {
    c.error = e.what();
  }
  return c;
}

// The pair's clouds, loaded on first use and kept (the city scan only as a model, for builds).
const Clouds& clouds(const std::string& pair) {
  static std::map<std::string, Clouds> loaded;
  auto it = loaded.find(pair);
  if (it != loaded.end()) return it->second;
  Clouds c;
  if (pair == kCityScan) {
    try {
      c.model = nnb::datasets::resolve_cloud(kCityScan, nnb::datasets::Role::model, data_options()).points;
    } catch (const std::exception& e) {
      c.error = e.what();
    }
  } else {
    for (const PairSpec& spec : pairs()) {
      if (spec.name == pair) c = load(spec);
    }
  }
  return loaded.emplace(pair, std::move(c)).first->second;
}


// The query scan of a real pair as ICP starts from it: in its own frame, with the pair's initial pose.
struct IcpQuery {
  nnb::Cloud points;
  Eigen::Matrix4d initial = Eigen::Matrix4d::Identity();
  std::string error;
};

const IcpQuery& icp_query(const std::string& pair) {
  static std::map<std::string, IcpQuery> loaded;
  auto it = loaded.find(pair);
  if (it != loaded.end()) return it->second;
  IcpQuery q;
  try {
    using nnb::datasets::PoseKind;
    const auto spec = nnb::datasets::find_pair(pair);
    if (!spec) throw std::runtime_error("no real pair " + pair);
    q.points = nnb::datasets::load_pair_scan(*spec, nnb::datasets::Role::query, data_options()).points;
    q.initial = nnb::datasets::load_pair_pose(*spec, PoseKind::initial, data_options()).value_or(q.initial);
  } catch (const std::exception& e) {
    q.error = e.what();
  }
  return loaded.emplace(pair, std::move(q)).first->second;
}

// The ICP settings of run_icp's icp_real experiment for that pair (the reference run's ICP, Figure 5).
nnb::icp::Options icp_options(const std::string& pair, const Eigen::Matrix4d& initial) {
  static const nnb::icp::Experiment experiment =
      nnb::icp::load_experiment(nnb::files::experiment_path(kIcpExperiment, NNB_EXPERIMENTS_DIR));
  const nnb::icp::Settings& s = nnb::icp::settings_for(experiment, pair);
  if (s.query_stride != 1 || s.threads != 1) throw std::runtime_error("icp_real must run every query on one thread");
  const nnb::icp::Options o = nnb::icp::options_of(s, initial);
  nnb::icp::validate(o);
  return o;
}

// Marks the benchmark skipped with why (error) when its input could not be had; returns whether it was.
bool skipped(benchmark::State& state, const std::string& error) {
  if (error.empty()) return false;
  state.SkipWithError(error.c_str());
  for (auto _ : state) {
  }
  return true;
}

bool skipped(benchmark::State& state, const Clouds& c) { return skipped(state, c.error); }

void bench_build(benchmark::State& state, const Subject& s, const std::string& pair, int threads) {
  const Clouds& c = clouds(pair);
  if (skipped(state, c)) return;
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto index = nnb::make_adapter(s.adapter, s.params);
    index->set_threads(threads);
    index->build(c.model);
    bytes = index->index_bytes();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes_per_point"] = double(bytes) / double(c.model.cols());
  state.counters["items_per_call"] = double(c.model.cols());
  state.SetItemsProcessed(state.iterations() * c.model.cols());
}

void bench_ranged(benchmark::State& state, const Subject& s, const std::string& pair, double max_dist_m, int threads,
                  int k = 1) {
  const Clouds& c = clouds(pair);
  if (skipped(state, c)) return;
  auto index = nnb::make_adapter(s.adapter, s.params);
  index->set_threads(threads);
  index->build(c.model);
  nnb::Neighbours out;
  for (auto _ : state) {
    index->ranged(c.queries, k, max_dist_m, out);
    benchmark::DoNotOptimize(out.indices.data());
  }
  state.counters["found"] = double(out.queries_with_neighbours());
  state.counters["bytes_per_point"] = double(index->index_bytes()) / double(c.model.cols());
  state.counters["items_per_call"] = double(c.queries.cols());
  state.counters["threads_used"] = double(index->threads_used());
  state.SetItemsProcessed(state.iterations() * c.queries.cols());
}

// ICP's work between two searches, on the pairs of one search: the fit, then every query point moved.
void bench_icp_step(benchmark::State& state, const std::string& pair) {
  const Clouds& c = clouds(pair);
  if (skipped(state, c)) return;
  // The pairs are what any exact adapter finds; ours finds them in milliseconds, brute force in minutes.
  auto index = nnb::make_adapter(nnb::adapter_built_in("ours_kdtree") ? "ours_kdtree" : "brute_force", {});
  index->build(c.model);
  nnb::Neighbours pairs;
  index->ranged(c.queries, 1, kIcpStepDistM, pairs);
  nnb::Cloud moved;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  for (auto _ : state) {
    double sum_sq_m2 = 0.0;
    const nnb::icp::PairMoments m = nnb::icp::pair_moments(pairs, c.queries, c.model, sum_sq_m2);
    benchmark::DoNotOptimize(nnb::icp::rigid_transform_from(m, pose));
    benchmark::DoNotOptimize(nnb::icp::sum_sq_after_m2(m, pose) + sum_sq_m2);
    nnb::icp::move_queries(c.queries, pose, moved);
    benchmark::DoNotOptimize(moved.data());
  }
  state.counters["items_per_call"] = double(pairs.queries_with_neighbours());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(pairs.queries_with_neighbours()));
}

// A whole ICP run with a subject's index, built once outside the timing (as run_icp reports it).
void bench_icp(benchmark::State& state, const Subject& s, const std::string& pair) {
  const Clouds& c = clouds(pair);
  if (skipped(state, c)) return;
  const IcpQuery& q = icp_query(pair);
  if (skipped(state, q.error)) return;
  nnb::icp::Options options;
  try {
    options = icp_options(pair, q.initial);
  } catch (const std::exception& e) {
    skipped(state, std::string("icp settings: ") + e.what());
    return;
  }
  auto index = nnb::make_adapter(s.adapter, s.params);
  index->build(c.model);
  nnb::icp::Result result;
  for (auto _ : state) {
    result = nnb::icp::register_prebuilt(*index, c.model, q.points, options);
    benchmark::DoNotOptimize(result.pose.data());
  }
  state.counters["icp_iterations"] = double(result.iterations);
  state.counters["items_per_call"] = double(q.points.cols());
}

std::string distance_text(double max_dist_m) {
  char text[16];
  std::snprintf(text, sizeof text, "%.2f", max_dist_m);
  return text;
}

std::string ranged_name(const std::string& pair, const std::string& label, double max_dist_m, int threads = 1,
                        int k = 1) {
  const std::string name = "Ranged" + std::to_string(k) + "NN/" + pair + "/" + label + "/" + distance_text(max_dist_m);
  return threads == 1 ? name : name + "/threads:" + std::to_string(threads);
}

// The distance of the 2-NN benchmarks.
constexpr double kTwoNearestDistM = 0.1;

// The pairs the threaded benchmarks run on.
bool threaded_pair(const PairSpec& pair) { return pair.name == "fig3" || pair.name == "office-sick-3dtk"; }

std::string build_name(const std::string& pair, const std::string& label, int threads = 1) {
  const std::string name = "Build/" + pair + "/" + label;
  return threads == 1 ? name : name + "/threads:" + std::to_string(threads);
}

// Our k-d tree builds on threads when given them (the others build on one).
const char* const kThreadedBuild = "ours_kdtree";

std::string icp_step_name(const std::string& pair) { return "IcpStep/" + pair; }
std::string icp_name(const std::string& pair, const std::string& label) { return "Icp/" + pair + "/" + label; }

// Ours and the anchors run everywhere; other libraries (for information) and our variants (to choose
// the defaults: the other scalar, other bucket and leaf sizes) on fig3 and the SICK pair only.
struct Subjects {
  std::vector<Subject> everywhere, fig3_and_sick;
};

Subjects subjects() {
  Subjects all;
  std::vector<std::string> skipped;
  for (const auto& list : {kOurs, kAnchors}) {
    for (const std::string& name : list) {
      if (nnb::adapter_built_in(name)) all.everywhere.push_back({name, name, {}});
      else skipped.push_back(name);
    }
  }
  // What answering in Morton order is worth (ours choose by default): always the caller's order, and
  // always Morton order.
  for (const std::string& name : kOurs) {
    if (!nnb::adapter_built_in(name)) continue;
    all.everywhere.push_back({name + "[order=caller]", name, {{"order", "caller"}}});
    all.fig3_and_sick.push_back({name + "[order=morton]", name, {{"order", "morton"}}});
  }
  for (const char* name : {"flann_kdtree", "pcl_octree", "ann_kdtree"}) {
    if (nnb::adapter_built_in(name)) all.fig3_and_sick.push_back({name, name, {}});
    else skipped.push_back(name);
  }
  // Each tree's bucket parameter as it declares it, with the sizes worth comparing with its default.
  const std::pair<const char*, std::vector<const char*>> variants[] = {
      {"ours_kdtree", {"8", "16", "32", "48", "96"}}, {"ours_octree", {"16", "32", "48", "64", "96", "128"}}};
  for (const auto& [name, sizes] : variants) {
    if (!nnb::adapter_built_in(name)) continue;
    all.fig3_and_sick.push_back({std::string(name) + "[float]", name, {{"scalar", "float"}}});
    const std::string bucket = nnb::make_adapter(name, {})->info().bucket->name;
    for (const char* size : sizes) {
      all.fig3_and_sick.push_back({std::string(name) + "[" + bucket + "=" + size + "]", name, {{bucket, size}}});
    }
  }
  std::cerr << "micro_nns: skipped (not built in):";
  for (const auto& name : skipped) std::cerr << ' ' << name;
  std::cerr << (skipped.empty() ? " none\n" : "\n");
  return all;
}

void register_all(const Subjects& all) {
  auto ms = [](benchmark::internal::Benchmark* b) { b->Unit(benchmark::kMillisecond); };
  for (const PairSpec& pair : pairs()) {
    const std::string p = pair.name;
    std::vector<Subject> here = all.everywhere;
    if (p == "fig3" || p == "office-sick-3dtk") here.insert(here.end(), all.fig3_and_sick.begin(), all.fig3_and_sick.end());
    for (const Subject& s : here) {
      if (!pair.shuffled) {
        ms(benchmark::RegisterBenchmark(build_name(p, s.label).c_str(),
                                        [s, p](benchmark::State& st) { bench_build(st, s, p, 1); }));
      }
      for (const double d : kDistancesM) {
        ms(benchmark::RegisterBenchmark(ranged_name(p, s.label, d).c_str(),
                                        [s, p, d](benchmark::State& st) { bench_ranged(st, s, p, d, 1); }));
      }
    }
    for (const Subject& s : threaded_pair(pair) ? all.everywhere : std::vector<Subject>{}) {
      for (int t = 2; t <= max_threads(); ++t) {
        for (const double d : kDistancesM) {  // wall time: the other threads' CPU time is not the caller's
          ms(benchmark::RegisterBenchmark(ranged_name(p, s.label, d, t).c_str(),
                                          [s, p, d, t](benchmark::State& st) { bench_ranged(st, s, p, d, t); })
                 ->UseRealTime());
        }
      }
    }
    if (!pair.shuffled) {
      for (const Subject& s : all.everywhere) {
        if (s.label != s.adapter) continue;  // ours and the anchors as they come
        const double d = kTwoNearestDistM;
        ms(benchmark::RegisterBenchmark(ranged_name(p, s.label, d, 1, 2).c_str(),
                                        [s, p, d](benchmark::State& st) { bench_ranged(st, s, p, d, 1, 2); }));
      }
      ms(benchmark::RegisterBenchmark(icp_step_name(p).c_str(), [p](benchmark::State& st) { bench_icp_step(st, p); }));
    }
    for (const Subject& s : pair.shuffled || pair.dataset.empty() ? std::vector<Subject>{} : all.everywhere) {
      if (s.label != s.adapter) continue;
      ms(benchmark::RegisterBenchmark(icp_name(p, s.label).c_str(), [s, p](benchmark::State& st) { bench_icp(st, s, p); }));
    }
  }
  for (const std::string& p : {std::string("fig3"), std::string(kCityScan)}) {
    const Subject s{kThreadedBuild, kThreadedBuild, {}};
    for (int t = 2; t <= max_threads() && nnb::adapter_built_in(kThreadedBuild); ++t) {
      ms(benchmark::RegisterBenchmark(build_name(p, s.label, t).c_str(),
                                      [s, p, t](benchmark::State& st) { bench_build(st, s, p, t); })
             ->UseRealTime());
    }
  }
  for (const Subject& s : all.everywhere) {
    const std::string p = kCityScan;
    ms(benchmark::RegisterBenchmark(build_name(p, s.label).c_str(), [s, p](benchmark::State& st) { bench_build(st, s, p, 1); }));
  }
}

// The console reporter, also keeping the fastest CPU time (ms) and the items of every benchmark.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  // Colours only on a terminal (this reporter replaces the one --benchmark_color would configure).
  RatioReporter() : ConsoleReporter(isatty(fileno(stdout)) ? OO_Defaults : OO_Tabular) {}

  void ReportRuns(const std::vector<Run>& reports) override {
    ConsoleReporter::ReportRuns(reports);
    for (const Run& run : reports) {
      if (run.run_type != Run::RT_Iteration || run.error_occurred) continue;
      std::string name = run.benchmark_name();
      const std::string wall_suffix = "/real_time";  // Google Benchmark's mark of UseRealTime
      if (name.size() > wall_suffix.size() && name.compare(name.size() - wall_suffix.size(), wall_suffix.size(), wall_suffix) == 0) {
        name.resize(name.size() - wall_suffix.size());
      }
      const double ms = run.GetAdjustedCPUTime();
      auto it = best_ms_.find(name);
      if (it == best_ms_.end() || ms < it->second) best_ms_[name] = ms;
      const double wall_ms = run.GetAdjustedRealTime();
      auto wall = best_wall_ms_.find(name);
      if (wall == best_wall_ms_.end() || wall_ms < wall->second) best_wall_ms_[name] = wall_ms;
      const auto items = run.counters.find("items_per_call");
      if (items != run.counters.end()) items_[name] = double(items->second.value);
    }
  }

  // The fastest CPU time (ms) of that benchmark, or nothing when it did not run.
  std::optional<double> ms(const std::string& name) const {
    auto it = best_ms_.find(name);
    if (it == best_ms_.end()) return std::nullopt;
    return it->second;
  }
  // Items (queries, points or correspondences) one call handled, or nothing when it did not run.
  // The fastest wall time (ms) of that benchmark, or nothing when it did not run.
  std::optional<double> wall_ms(const std::string& name) const {
    auto it = best_wall_ms_.find(name);
    if (it == best_wall_ms_.end()) return std::nullopt;
    return it->second;
  }

  std::optional<double> items(const std::string& name) const {
    auto it = items_.find(name);
    if (it == items_.end() || !(it->second > 0)) return std::nullopt;
    return it->second;
  }

 private:
  std::map<std::string, double> best_ms_;
  std::map<std::string, double> best_wall_ms_;
  std::map<std::string, double> items_;
};

// Counts the verdicts printed, for the summary line.
struct Tally {
  int pass = 0, miss = 0, not_run = 0;
};

// "2.31x >= 2 PASS", "84 ns < 100 MISS" or "not run"; counted in tally.
std::string verdict(std::optional<double> value, double target, bool at_least, const char* unit, Tally& tally) {
  if (!value) {
    ++tally.not_run;
    return "not run";
  }
  const bool pass = at_least ? *value >= target : *value < target;
  ++(pass ? tally.pass : tally.miss);
  char text[48];
  std::snprintf(text, sizeof text, "%.2f%s %s %g %s", *value, unit, at_least ? ">=" : "<", target, pass ? "PASS" : "MISS");
  return text;
}

std::optional<double> faster(std::optional<double> a, std::optional<double> b) {
  if (a && b) return std::min(*a, *b);
  return a ? a : b;
}

std::optional<double> ratio(std::optional<double> theirs, std::optional<double> ours) {
  if (!theirs || !ours) return std::nullopt;
  return *theirs / *ours;
}

// Nanoseconds per item (query, point or correspondence) of a benchmark, when it ran.
std::optional<double> ns_per_item(const RatioReporter& r, const std::string& name) {
  const auto ms = r.ms(name);
  const auto items = r.items(name);
  if (!ms || !items) return std::nullopt;
  return *ms * 1e6 / *items;
}

std::string number(std::optional<double> value) {
  if (!value) return "-";
  char text[24];
  std::snprintf(text, sizeof text, "%.1f", *value);
  return text;
}

// Target 1 (ours >= 2x the faster nanoflann) and target 2 (under 100 ns a query at <= 0.1 m).
void print_ranged_targets(const RatioReporter& r, Tally& tally) {
  std::printf("\nRanged 1-NN, ns per query (fastest repetition, CPU time); ratio = the faster nanoflann / the faster of ours:\n");
  std::printf("%-34s %5s | %8s %8s | %9s %9s | %-20s | %s\n", "pair", "d [m]", "kdtree", "octree", "nanoflann",
              "latest", "ratio (target 2x)", "ours (target < 100 ns)");
  for (const PairSpec& pair : pairs()) {
    for (const double d : kDistancesM) {
      auto ns = [&](const std::string& label) { return ns_per_item(r, ranged_name(pair.name, label, d)); };
      const auto kd = ns("ours_kdtree"), oc = ns("ours_octree");
      const auto nano = ns("nanoflann_kdtree"), latest = ns("nanoflann_latest");
      const auto ours = faster(kd, oc);
      const std::string fast = pair.fast_target && d <= 0.1 ? verdict(ours, 100.0, false, " ns", tally) : "-";
      std::printf("%-34s %5.2f | %8s %8s | %9s %9s | %-20s | %s\n", pair.name.c_str(), d, number(kd).c_str(),
                  number(oc).c_str(), number(nano).c_str(), number(latest).c_str(),
                  verdict(ratio(faster(nano, latest), ours), 2.0, true, "x", tally).c_str(), fast.c_str());
    }
  }
}

// For information (no target): ranged 2-NN, what ICP's tracked neighbours ask.
void print_two_nearest(const RatioReporter& r) {
  std::printf("\nRanged 2-NN at %.2f m, ns per query (for information); ratio = the faster nanoflann / the faster of ours:\n",
              kTwoNearestDistM);
  std::printf("%-34s | %8s %8s | %9s %9s | %s\n", "pair", "kdtree", "octree", "nanoflann", "latest", "ratio");
  for (const PairSpec& pair : pairs()) {
    if (pair.shuffled) continue;
    auto ns = [&](const std::string& label) { return ns_per_item(r, ranged_name(pair.name, label, kTwoNearestDistM, 1, 2)); };
    const auto kd = ns("ours_kdtree"), oc = ns("ours_octree"), nano = ns("nanoflann_kdtree"), latest = ns("nanoflann_latest");
    std::printf("%-34s | %8s %8s | %9s %9s | %s\n", pair.name.c_str(), number(kd).c_str(), number(oc).c_str(),
                number(nano).c_str(), number(latest).c_str(), number(ratio(faster(nano, latest), faster(kd, oc))).c_str());
  }
}

// Target 5: ours at least 1.8x faster on 2 threads than on one (wall time); more threads for information.
void print_thread_targets(const RatioReporter& r, Tally& tally) {
  if (max_threads() < 2) return;
  std::printf("\nRanged 1-NN on threads, speed-up of the wall time over one thread (this machine reports %u hardware "
              "threads):\n", std::thread::hardware_concurrency());
  std::printf("%-20s %5s %8s | %8s %8s %9s %9s | %s\n", "pair", "d [m]", "threads", "kdtree", "octree", "nanoflann",
              "latest", "ours (target 1.8x at 2)");
  for (const PairSpec& pair : pairs()) {
    if (!threaded_pair(pair)) continue;
    for (const double d : kDistancesM) {
      for (int t = 2; t <= max_threads(); ++t) {
        auto gain = [&](const std::string& label) {
          return ratio(r.wall_ms(ranged_name(pair.name, label, d)), r.wall_ms(ranged_name(pair.name, label, d, t)));
        };
        const auto kd = gain("ours_kdtree"), oc = gain("ours_octree");
        const auto ours = kd && oc ? std::optional<double>(std::max(*kd, *oc)) : (kd ? kd : oc);
        const std::string judged = t == 2 ? verdict(ours, kThreadTarget, true, "x", tally) : "-";
        std::printf("%-20s %5.2f %8d | %8s %8s %9s %9s | %s\n", pair.name.c_str(), d, t, number(kd).c_str(),
                    number(oc).c_str(), number(gain("nanoflann_kdtree")).c_str(),
                    number(gain("nanoflann_latest")).c_str(), judged.c_str());
      }
    }
  }
}

// Target 4: ICP's step between searches under 10 ns a correspondence.
void print_icp_step_target(const RatioReporter& r, Tally& tally) {
  std::printf("\nICP step between searches (fit + moving the queries), ns per correspondence of a %.1f m search:\n",
              kIcpStepDistM);
  for (const PairSpec& pair : pairs()) {
    if (pair.shuffled) continue;
    std::printf("%-34s %s\n", pair.name.c_str(),
                verdict(ns_per_item(r, icp_step_name(pair.name)), 10.0, false, " ns", tally).c_str());
  }
}

// Target 3: ICP with ours at least 2.5x faster than with the faster nanoflann, on every real pair.
void print_icp_targets(const RatioReporter& r, Tally& tally) {
  std::printf("\nICP on the real pairs (%s's settings, from the initial pose, construction excluded), ms (fastest "
              "repetition, CPU time); ratio = the faster nanoflann / the faster of ours:\n", kIcpExperiment);
  std::printf("%-34s | %9s %9s | %9s %9s | %s\n", "pair", "kdtree", "octree", "nanoflann", "latest", "ratio (target 2.5x)");
  for (const PairSpec& pair : pairs()) {
    if (pair.shuffled || pair.dataset.empty()) continue;
    auto ms = [&](const std::string& label) { return r.ms(icp_name(pair.name, label)); };
    const auto kd = ms("ours_kdtree"), oc = ms("ours_octree"), nano = ms("nanoflann_kdtree"), latest = ms("nanoflann_latest");
    std::printf("%-34s | %9s %9s | %9s %9s | %s\n", pair.name.c_str(), number(kd).c_str(), number(oc).c_str(),
                number(nano).c_str(), number(latest).c_str(),
                verdict(ratio(faster(nano, latest), faster(kd, oc)), kIcpTarget, true, "x", tally).c_str());
  }
}

// Target 6: each of our trees building at least 2x faster than the faster nanoflann.
void print_build_targets(const RatioReporter& r, Tally& tally) {
  std::printf("\nBuild, ms (fastest repetition, CPU time); ratio = the faster nanoflann / each of ours (target 2x for each):\n");
  std::printf("%-34s | %9s %9s | %9s %9s | %-18s | %s\n", "model", "kdtree", "octree", "nanoflann", "latest",
              "kdtree ratio", "octree ratio");
  std::vector<std::string> models;
  for (const PairSpec& pair : pairs()) {
    if (!pair.shuffled) models.push_back(pair.name);
  }
  models.push_back(kCityScan);
  for (const std::string& model : models) {
    auto ms = [&](const std::string& label) { return r.ms(build_name(model, label)); };
    const auto kd = ms("ours_kdtree"), oc = ms("ours_octree"), nano = ms("nanoflann_kdtree"), latest = ms("nanoflann_latest");
    const auto anchor = faster(nano, latest);
    const std::string kd_judged = verdict(ratio(anchor, kd), 2.0, true, "x", tally);
    std::printf("%-34s | %9s %9s | %9s %9s | %-18s | %s\n", model.c_str(), number(kd).c_str(), number(oc).c_str(),
                number(nano).c_str(), number(latest).c_str(), kd_judged.c_str(),
                verdict(ratio(anchor, oc), 2.0, true, "x", tally).c_str());
  }
}

// For information (no target): our k-d tree's build on threads, wall time, against one thread.
void print_threaded_builds(const RatioReporter& r) {
  if (max_threads() < 2) return;
  std::printf("\nBuild on threads (%s), ms of wall time and the speed-up over one thread:\n", kThreadedBuild);
  for (const std::string& model : {std::string("fig3"), std::string(kCityScan)}) {
    for (int t = 2; t <= max_threads(); ++t) {
      const auto one = r.wall_ms(build_name(model, kThreadedBuild)), many = r.wall_ms(build_name(model, kThreadedBuild, t));
      std::printf("%-34s %2d threads: %9s ms, %sx\n", model.c_str(), t, number(many).c_str(), number(ratio(one, many)).c_str());
    }
  }
}

void print_targets(const RatioReporter& r) {
  Tally tally;
  if (!nnb::adapter_built_in("nanoflann_latest")) {
    std::printf("\nnanoflann_latest is not built in (configure with NNB_NANOFLANN_LATEST_DIR, see scripts/anchors.sh): "
                "the anchor is Debian's nanoflann alone.\n");
  }
  print_ranged_targets(r, tally);
  print_two_nearest(r);
  print_thread_targets(r, tally);
  print_icp_targets(r, tally);
  print_icp_step_target(r, tally);
  print_build_targets(r, tally);
  print_threaded_builds(r);
  std::printf("\nTargets: %d PASS, %d MISS, %d not run\n", tally.pass, tally.miss, tally.not_run);
}

// Index memory per model point on the Figure 3 model, by part for ours, as reported by the adapter
// for the others (what each counts is in its index_bytes()).
void print_memory(const Subjects& all) {
  const nnb::Cloud& model = clouds("fig3").model;
  const double n = double(model.cols());
  std::printf("\nIndex memory per model point (fig3 model, %d points):\n", int(model.cols()));
  if (nnb::adapter_built_in("ours_kdtree") && nnb::adapter_built_in("ours_octree")) {
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
  std::vector<Subject> libraries = all.everywhere;
  libraries.insert(libraries.end(), all.fig3_and_sick.begin(), all.fig3_and_sick.end());
  for (const Subject& s : libraries) {
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
      std::cout << "micro_nns: ours against the best packaged tree: ranged 1-NN, build, ICP step (times in ms),\n"
                << "then the targets with PASS/MISS\n"
                << "  --version          " << "print the version, git commit and build type, and exit\n"
                << "  --data-dir DIR     " << nnb::cli::kDataDirHelp << "\n"
                << "  --threads N        " << "the threaded benchmarks run on 2 to N threads (default 2; 1: none)\n"
                << "and Google Benchmark's options:\n";
      argv[kept++] = argv[i];
    } else if (arg == "--threads" || arg.rfind("--threads=", 0) == 0) {
      const std::string value = arg == "--threads" ? (i + 1 < argc ? argv[++i] : "") : arg.substr(std::strlen("--threads="));
      char* end = nullptr;
      const long threads = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || threads < 1 || threads > nnb::SearchIndex::kMaxThreads) {
        std::cerr << "micro_nns: error: --threads needs a whole number from 1 to " << nnb::SearchIndex::kMaxThreads
                  << " (got '" << value << "')\n";
        return 2;
      }
      max_threads() = static_cast<int>(threads);
    } else if (arg == "--data-dir" || arg.rfind("--data-dir=", 0) == 0) {
      if (arg == "--data-dir" && i + 1 == argc) {
        std::cerr << "micro_nns: error: --data-dir needs a folder (see --help)\n";
        return 2;
      }
      data_dir() = arg == "--data-dir" ? argv[++i] : arg.substr(std::strlen("--data-dir="));
      std::error_code error;
      if (!std::filesystem::is_directory(data_dir(), error)) {  // else every real pair reads "not run"
        std::cerr << "micro_nns: error: --data-dir: not a folder: " << data_dir() << "\n";
        return 2;
      }
    } else if (arg.rfind("--benchmark_out=", 0) == 0) {
      out_path() = arg.substr(std::strlen("--benchmark_out="));
      out_argument() = "--benchmark_out=" + nnb::files::temporary_path(out_path());
      argv[kept++] = out_argument().data();
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  return std::nullopt;
}

// What this project's results files record of a run, in Google Benchmark's context (its own has no commit).
void add_provenance() {
  const nnb::bench::BuildInfo build = nnb::bench::read_build_info();
  benchmark::AddCustomContext("git_commit", build.git_commit);
  benchmark::AddCustomContext("command_line", nnb::bench::read_run_info().command_line);
  benchmark::AddCustomContext("nnb_build_type", build.build_type + (build.sanitizers ? "+sanitizers" : ""));
}

}  // namespace

int main(int argc, char** argv) {
  nnb::bench::mark_run_start(argc, argv);
  if (const auto code = take_shared_options(argc, argv)) return *code;
  benchmark::Initialize(&argc, argv);
  add_provenance();
  if (argc > 1) {
    std::cerr << "micro_nns: error: unknown option '" << argv[1] << "' (see --help)\n";
    return 2;
  }
  std::optional<nnb::files::OutputLock> lock;
  try {
    if (!out_argument().empty()) {  // given, even if empty
      nnb::files::check_output_path(out_path());
      lock.emplace(out_path());
      nnb::files::remove_stale_temporaries(out_path());
    }
  } catch (const nnb::InputError& e) {
    std::cerr << "micro_nns: error: " << e.what() << "\n";
    return 2;
  }
  const Subjects all = subjects();
  register_all(all);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_targets(reporter);
  print_memory(all);
  benchmark::Shutdown();
  return out_argument().empty() ? 0 : nnb::cli::run_reporting_errors("micro_nns", [] {
    nnb::files::commit_temporary(out_path());
    return 0;
  });
}
