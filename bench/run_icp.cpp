// run_icp: point-to-point ICP of a query cloud onto a model cloud with any adapter as the
// nearest-neighbour search, or a whole ICP experiment (bench/experiments/icp_*.json), or one shard of it
// (--shard I/N, split by sweep/shard.hpp's rule; --plan prints the split).
#include "cli_common.hpp"
#include "machine.hpp"
#include "progress.hpp"
#include "icp.hpp"
#include "icp_experiment.hpp"
#include "icp_plan.hpp"
#include "icp_record.hpp"
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/poses.hpp"
#include "nnb/registry.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <unistd.h>

namespace {

namespace ds = nnb::datasets;
namespace icp = nnb::icp;
using nnb::InputError;
using nnb::sweep::ShardSpec;

// What ICP runs on: clouds in metres, the query not moved, and the pair's poses when it has them.
struct Input {
  std::string label;
  nnb::Cloud model;
  nnb::Cloud query;
  Eigen::Matrix4d initial = Eigen::Matrix4d::Identity();
  std::optional<Eigen::Matrix4d> reference;
};

nnb::Cloud every_nth(const nnb::Cloud& cloud, std::size_t stride) {
  if (stride <= 1) return cloud;
  nnb::Cloud out(3, static_cast<Eigen::Index>((static_cast<std::size_t>(cloud.cols()) + stride - 1) / stride));
  for (Eigen::Index i = 0; i < out.cols(); ++i) out.col(i) = cloud.col(i * static_cast<Eigen::Index>(stride));
  return out;
}

// How a pair is named in records: a pair or shape by its name, a file by its stem.
std::string pair_label(const std::string& spec) {
  if (ds::find_pair(spec) || !std::filesystem::exists(spec)) return spec;
  return std::filesystem::path(spec).stem().string();
}

// A real pair as query gives its raw query scan plus its initial pose (identity when it lists none)
// and reference; anything else goes through resolve_cloud and starts at identity.
Input load_input(const std::string& model_spec, const std::string& query_spec, const ds::DataOptions& options,
                 std::size_t query_stride) {
  Input in;
  in.label = model_spec == query_spec ? pair_label(model_spec) : pair_label(model_spec) + "+" + pair_label(query_spec);
  if (const auto pair = ds::find_pair(model_spec)) {
    in.model = ds::load_pair_scan(*pair, ds::Role::model, options).points;
  } else {
    in.model = ds::resolve_cloud(model_spec, ds::Role::model, options).points;
  }
  nnb::Cloud query;
  if (const auto pair = ds::find_pair(query_spec)) {
    query = ds::load_pair_scan(*pair, ds::Role::query, options).points;
    in.initial = ds::load_pair_pose(*pair, ds::PoseKind::initial, options).value_or(Eigen::Matrix4d::Identity());
    in.reference = ds::load_pair_pose(*pair, ds::PoseKind::reference, options);
  } else {
    query = ds::resolve_cloud(query_spec, ds::Role::query, options).points;
  }
  in.query = every_nth(query, query_stride);
  return in;
}

// The adapter's bucket/leaf-size parameter, if it declares one (Figure 2's x axis).
std::string bucket_param_of(const nnb::AdapterInfo& info) { return info.bucket ? info.bucket->name : ""; }

icp::Record run_one(const Input& in, const std::string& adapter, const nnb::Params& params, const icp::Settings& s,
                    const Eigen::Matrix4d& initial, int repetition) {
  const icp::Options options = icp::options_of(s, initial);
  auto index = nnb::make_adapter(adapter, params);
  index->set_threads(s.threads);
  icp::Record rec;
  rec.pair = in.label;
  rec.adapter = adapter;
  rec.params = index->info().params;
  rec.bucket_param = bucket_param_of(index->info());
  if (const auto& bucket = index->info().bucket) rec.bucket_size = bucket->value;
  rec.model_points = static_cast<std::size_t>(in.model.cols());
  rec.query_points = static_cast<std::size_t>(in.query.cols());
  rec.query_stride = s.query_stride;
  rec.threads = index->threads_used();
  rec.options = options;
  rec.repetition = repetition;
  rec.reference = in.reference;

  using Clock = std::chrono::steady_clock;
  icp::validate(options);
  auto start = Clock::now();
  index->build(in.model);
  const double build_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const std::clock_t cpu_start = std::clock();
  start = Clock::now();
  rec.result = icp::register_prebuilt(*index, in.model, in.query, options);
  rec.icp_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  rec.icp_cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  rec.result.build_seconds = build_seconds;
  return rec;
}

void print_summary(std::ostream& out, const icp::Record& rec, bool per_iteration) {
  const auto& r = rec.result;
  out << icp::record_name(rec) << ": " << r.iterations << " iterations, "
      << (r.converged ? "converged" : "NOT converged") << (r.failure.empty() ? "" : " (" + r.failure + ")")
      << ", rms " << r.final_rms_m() << " m, " << r.final_correspondences() << "/" << rec.query_points
      << " pairs; icp " << rec.icp_seconds << " s (nns " << r.nns_seconds << " s, estimate " << r.estimate_seconds
      << " s), build " << r.build_seconds << " s\n";
  if (const auto t = icp::reference_translation_error_m(rec)) {
    out << "  vs reference: translation " << *t << " m, rotation " << *icp::reference_rotation_error_deg(rec)
        << " deg\n";
  }
  if (!per_iteration) return;
  out << "  final_pose (query -> model frame):\n" << std::setprecision(9);
  for (int row = 0; row < 4; ++row) {
    out << "   ";
    for (int col = 0; col < 4; ++col) out << " " << std::setw(14) << r.pose(row, col);
    out << "\n";
  }
  out << std::setprecision(6) << "  iteration  max_dist_m  pairs  rms_m  rms_after_m\n";
  for (std::size_t i = 0; i < r.per_iteration.size(); ++i) {
    const auto& it = r.per_iteration[i];
    out << "  " << i + 1 << "  " << it.max_dist_m << "  " << it.correspondences << "  " << it.rms_m << "  "
        << it.rms_after_m << "\n";
  }
}

icp::RunContext run_context(const std::string& experiment, const ds::DataOptions& data) {
  return {experiment, data.data_dir.empty() ? ds::default_data_dir() : data.data_dir, "", ""};
}

std::string experiment_path(const std::string& name) { return nnb::files::experiment_path(name, NNB_EXPERIMENTS_DIR); }

nnb::Params params_of(const icp::Experiment& e, const std::string& adapter) {
  const auto it = e.params.find(adapter);
  return it == e.params.end() ? nnb::Params{} : it->second;
}

// The experiment's adapters (its list or set, less the excluded) as made with its parameters.
std::vector<nnb::AdapterInfo> adapters_of(const icp::Experiment& e) {
  std::vector<std::string> names = e.adapters.empty() ? nnb::adapter_names() : e.adapters;
  std::vector<nnb::AdapterInfo> chosen;
  for (const auto& name : names) {
    if (std::find(e.exclude.begin(), e.exclude.end(), name) != e.exclude.end()) continue;
    auto info = nnb::make_adapter(name, params_of(e, name))->info();
    if (e.adapter_set == "with_bucket" && bucket_param_of(info).empty()) continue;
    chosen.push_back(std::move(info));
  }
  return chosen;
}

// One adapter setting of the experiment: the parameters of a bucket size, and the size records name.
struct Setting {
  std::string adapter;
  nnb::Params params;
  std::string bucket_param;
  std::optional<int> bucket_size;
};

// Every adapter at every bucket size of the experiment (its own value when it has no bucket parameter or
// the experiment gives none). A size the library refuses is left out with a line in refused: it would be
// refused on every pair and in every shard alike.
std::vector<Setting> settings_of(const icp::Experiment& e, const std::vector<nnb::AdapterInfo>& adapters,
                                 std::vector<std::string>& refused) {
  std::vector<Setting> settings;
  for (const auto& info : adapters) {
    const std::string bucket_param = bucket_param_of(info);
    std::vector<std::optional<int>> buckets{std::nullopt};
    if (!e.bucket_sizes.empty() && !bucket_param.empty()) buckets.assign(e.bucket_sizes.begin(), e.bucket_sizes.end());
    const auto best = e.best_buckets.find(info.name);
    if (buckets.front() == std::nullopt && !bucket_param.empty() && best != e.best_buckets.end() &&
        !params_of(e, info.name).count(bucket_param)) {
      buckets.front() = best->second;
    }
    for (const auto& bucket : buckets) {
      nnb::Params params = params_of(e, info.name);
      if (bucket) params[bucket_param] = std::to_string(*bucket);
      try {
        const auto made = nnb::make_adapter(info.name, params)->info();
        const auto size = made.bucket ? std::optional<int>(made.bucket->value) : std::nullopt;
        settings.push_back({info.name, params, bucket_param, size});
      } catch (const InputError& err) {
        refused.push_back("skipped " + info.name + " " + bucket_param + "=" + std::to_string(bucket.value_or(0)) +
                          ": " + err.what());
      }
    }
  }
  return settings;
}

// The units in run order: each pair with each setting, its repetitions as cells.
icp::Plan plan_units(const icp::Experiment& e, const std::vector<Setting>& settings, int shards) {
  icp::Plan plan;
  plan.count = shards;
  std::set<std::string> cells;
  for (const auto& spec : e.pairs) {
    for (const auto& s : settings) {
      icp::Unit unit{spec, pair_label(spec), s.adapter, s.params, s.bucket_param, s.bucket_size, {}, 0.0, 0};
      for (int rep = 0; rep < e.repetitions; ++rep) {
        unit.cells.push_back(icp::cell_name(icp::record_name(unit.pair, unit.adapter, unit.bucket_size), rep));
        if (!cells.insert(unit.cells.back()).second) {
          throw InputError("the experiment runs " + unit.cells.back() +
                           " twice: a pair, adapter or bucket size is listed twice");
        }
      }
      plan.units.push_back(std::move(unit));
    }
  }
  return plan;
}

// Each unit's expected cost (icp::kCostModel): every search of an iteration costs about the same in a tree,
// so query points x iterations, the build once per run; the iteration limit, as convergence is not known
// before. Each pair is loaded once, for its sizes.
void price_units(icp::Plan& plan, const icp::Experiment& e, const ds::DataOptions& data) {
  std::map<std::string, std::pair<double, double>> points;  // by pair: model, query (after the stride)
  for (auto& unit : plan.units) {
    const icp::Settings& s = icp::settings_for(e, unit.spec);
    auto it = points.find(unit.spec);
    if (it == points.end()) {
      const Input in = load_input(unit.spec, unit.spec, data, s.query_stride);
      it = points.emplace(unit.spec, std::pair<double, double>(in.model.cols(), in.query.cols())).first;
    }
    const auto [model, query] = it->second;
    const double work = e.repetitions * (query * s.max_iterations + model);
    unit.cost = nnb::sweep::adapter_cost_factor(unit.adapter) * work * 1e-6;
  }
}

void print_plan(std::ostream& out, const icp::Plan& plan, const icp::Experiment& e, const ShardSpec& shard,
                const std::vector<std::string>& refused, bool as_json) {
  if (as_json) {
    out << icp::plan_json(plan, e, shard, refused) << "\n";
    return;
  }
  out << "plan: experiment '" << e.name << "': " << plan.total_cells << " cells in " << plan.units.size()
      << " units (pair x adapter x bucket size, one ICP run per repetition) over " << plan.count << " shards\n"
      << "expected cost: (query points x iteration limit + model points) x repetitions x adapter factor ("
      << nnb::sweep::adapter_cost_factors_text() << "), in 1e6\n";
  nnb::sweep::print_shard_table(out, plan, shard);
  for (const auto& line : refused) out << line << "\n";
  if (!shard.given) return;
  out << "units of shard " << nnb::sweep::shard_label(shard) << ":\n";
  for (const auto& u : plan.units) {
    if (u.shard != shard.index) continue;
    const std::string bucket = u.bucket_size ? std::to_string(*u.bucket_size) : "default";
    out << "  " << u.pair << " " << u.adapter << " bucket:" << bucket << ": " << u.cells.size() << " cells, cost "
        << std::fixed << std::setprecision(1) << u.cost << std::defaultfloat << "\n";
  }
}

// The experiment's results file: the records of the file it resumes, then this run's, rewritten atomically
// after every run so that a killed run loses at most the one under way.
class ResultsFile {
 public:
  ResultsFile(std::string path, icp::RunContext run) : path_(std::move(path)), run_(std::move(run)) {}

  /// Keeps the records of an existing file made with the same configuration; false when there is none.
  bool resume() {
    if (!std::filesystem::exists(path_)) return false;
    resumed_ = icp::read_resumable(path_, run_);
    texts_ = resumed_.records;
    cells_.insert(resumed_.cells.begin(), resumed_.cells.end());
    return true;
  }
  bool has(const std::string& cell) const { return cells_.count(cell) > 0; }
  void add(const icp::Record& rec) {
    texts_.push_back(icp::record_text(rec));
    cells_.insert(icp::cell_name(icp::record_name(rec), rec.repetition));
    write();
  }
  void write() const {
    nnb::files::write_file_atomically(path_, icp::results_json(texts_, nnb::cli::build_type(), run_, resumed_.context));
  }
  std::size_t size() const { return texts_.size(); }

 private:
  std::string path_;
  icp::RunContext run_;
  icp::Resumed resumed_;
  std::vector<std::string> texts_;
  std::set<std::string> cells_;
};

// The repetitions of one unit not yet in the file. A library that refuses the cloud itself (at build) skips
// the rest of its unit.
void run_unit(const icp::Unit& unit, const Input& in, const icp::Settings& s, ResultsFile& results,
              nnb::bench::Progress& progress) {
  const std::string bucket =
      unit.bucket_size ? " " + unit.bucket_param + "=" + std::to_string(*unit.bucket_size) : std::string();
  for (int rep = 0; rep < static_cast<int>(unit.cells.size()); ++rep) {
    if (results.has(unit.cells[rep])) continue;
    progress.begin(unit.spec + " " + unit.adapter + bucket);
    icp::Record rec;
    try {
      rec = run_one(in, unit.adapter, unit.params, s, in.initial, rep);
    } catch (const InputError& err) {
      std::cout << "skipped " << unit.adapter << bucket << ": " << err.what() << "\n";
      progress.end(unit.cells.size() - rep, std::string("skipped: ") + err.what());
      return;
    }
    progress.end(1, rec.result.failure.empty() ? "done" : rec.result.failure);
    print_summary(std::cout, rec, false);
    results.add(rec);
  }
}

// The units of one shard in plan order, each pair loaded when a cell of it is still to run.
void run_units(const icp::Plan& plan, int shard, const icp::Experiment& e, const ds::DataOptions& data,
               ResultsFile& results, nnb::bench::Progress& progress) {
  std::optional<Input> in;
  std::string loaded;  // the pair in `in`
  for (const auto& unit : plan.units) {
    if (unit.shard != shard) continue;
    if (std::all_of(unit.cells.begin(), unit.cells.end(), [&](const auto& c) { return results.has(c); })) continue;
    const icp::Settings& s = icp::settings_for(e, unit.spec);
    if (!in || loaded != unit.spec) {
      in.reset();  // one pair in memory at a time
      in = load_input(unit.spec, unit.spec, data, s.query_stride);
      loaded = unit.spec;
    }
    run_unit(unit, *in, s, results, progress);
  }
}

struct ExperimentFlags {
  std::string name, out, shard;
  std::optional<std::string> buckets_from;  ///< overrides the experiment's; "none": each adapter's default
  std::optional<int> threads;               ///< overrides the experiment's
  bool resume = false, plan = false, plan_json = false;
};

// The experiment's units in run order, split into shards; priced (which loads every pair once) only when the
// split matters, as a single run takes them all.
icp::Plan make_plan(const icp::Experiment& e, const std::vector<nnb::AdapterInfo>& adapters, const ShardSpec& shard,
                    bool priced, const ds::DataOptions& data, std::vector<std::string>& refused) {
  icp::Plan plan = plan_units(e, settings_of(e, adapters, refused), shard.count);
  if (priced) price_units(plan, e, data);
  nnb::sweep::assign_longest_first(plan);
  return plan;
}

// What the results file says of an experiment run: its configuration (the shard in it, so that a resume as
// another shard is refused) and the shard's plan.
icp::RunContext experiment_context(const icp::Experiment& e, const std::vector<nnb::AdapterInfo>& adapters,
                                   const icp::Plan& plan, const ShardSpec& shard, const ds::DataOptions& data) {
  std::vector<icp::AdapterVersion> versions;
  for (const auto& a : adapters) versions.push_back({a.name, a.version});
  icp::RunContext run = run_context(e.name, data);
  run.config = icp::config_json(e, versions, data.synthetic_points, data.seed, nnb::cli::build_type(),
                                nnb::sweep::shard_config_json(shard));
  run.shard = icp::shard_context_json(plan, shard);
  return run;
}

// Each adapter at its best bucket from the file the experiment (or --buckets-from) names, said on stdout.
void choose_buckets(icp::Experiment& e, const ExperimentFlags& flags) {
  if (flags.buckets_from) e.buckets_from = *flags.buckets_from == "none" ? "" : *flags.buckets_from;
  if (e.buckets_from.empty()) return;
  e.best_buckets = icp::best_buckets(e.buckets_from);
  std::cout << "best buckets from " << e.buckets_from << ":";
  for (const auto& [adapter, bucket] : e.best_buckets) std::cout << " " << adapter << "=" << bucket;
  std::cout << " (other adapters at their default)\n";
}

int run_experiment(const ExperimentFlags& flags, const ds::DataOptions& data) {
  icp::Experiment e = icp::load_experiment(experiment_path(flags.name));
  choose_buckets(e, flags);
  if (flags.threads) {
    e.icp.threads = *flags.threads;
    for (auto& [pair, settings] : e.icp_by_pair) settings.threads = *flags.threads;
  }
  const ShardSpec shard = flags.shard.empty() ? ShardSpec{} : nnb::sweep::parse_shard(flags.shard);
  const auto adapters = adapters_of(e);
  std::vector<std::string> refused;
  const icp::Plan plan = make_plan(e, adapters, shard, shard.given || flags.plan, data, refused);
  if (flags.plan) {
    print_plan(std::cout, plan, e, shard, refused, flags.plan_json);
    return 0;
  }
  const std::string out_path = flags.out.empty() ? nnb::sweep::shard_path(e.out, shard) : flags.out;
  std::vector<std::string> inputs{experiment_path(flags.name)};
  if (!e.buckets_from.empty()) inputs.push_back(e.buckets_from);
  nnb::files::check_output_path(out_path, inputs);
  const nnb::files::OutputLock lock(out_path);
  nnb::files::remove_stale_temporaries(out_path);
  ResultsFile results(out_path, experiment_context(e, adapters, plan, shard, data));
  if (flags.resume) {
    if (!results.resume()) std::cerr << "run_icp: --resume: " << out_path << " does not exist yet, starting afresh\n";
  } else if (std::filesystem::exists(out_path)) {
    std::cerr << "run_icp: note: replacing " << out_path << " (--resume continues it)\n";
  }

  const auto cells = plan.cells_of(shard.index);
  const auto already = static_cast<std::size_t>(
      std::count_if(cells.begin(), cells.end(), [&](const auto& c) { return results.has(c); }));
  std::cout << "experiment " << e.name << (shard.given ? ", shard " + flags.shard : std::string()) << ": "
            << e.pairs.size() << " pair(s), " << cells.size() << " runs (" << already
            << " already in the file), adapters:";
  for (const auto& a : adapters) std::cout << " " << a.name;
  std::cout << "\nwriting " << out_path << "\n";
  for (const auto& line : refused) std::cout << line << "\n";
  nnb::bench::Progress progress(cells.size(), already, isatty(STDERR_FILENO) != 0);
  run_units(plan, shard.index, e, data, results, progress);
  progress.finish();
  results.write();  // also when the shard has nothing (left) to run, so that every shard has its file
  std::cout << results.size() << " records written to " << out_path << "\n";
  return 0;
}

// One ICP run from the command line (without --experiment).
struct SingleRun {
  std::string adapter, model_spec, query_spec, initial_file, out_path;
  std::vector<std::string> param_words;
  icp::Settings settings;
  ds::DataOptions data;
};

void add_flags(CLI::App& app, ExperimentFlags& experiment, SingleRun& one) {
  icp::Settings& s = one.settings;
  s.max_dist.start_m = 0.25;
  app.add_option("--experiment", experiment.name, "run an ICP experiment: a name in bench/experiments or a file");
  app.add_flag("--resume", experiment.resume,
               "with --experiment: finish the runs missing from --out (same configuration only)");
  app.add_option("--shard", experiment.shard,
                 "with --experiment: I/N: run only shard I (from 0) of N, balanced by expected cost");
  app.add_flag("--plan", experiment.plan,
               "with --experiment: print the runs, units and shards with their expected cost; run nothing");
  app.add_flag("--json", experiment.plan_json, "with --plan: print the plan as JSON");
  app.add_option("--buckets-from", experiment.buckets_from,
                 "with --experiment: run each adapter at its fastest bucket in this ICP results file (a bucket "
                 "sweep, Figure 2); 'none': every adapter at its default");
  app.add_option("--adapter", one.adapter, "nearest-neighbour adapter (see nns_query --list)");
  app.add_option("--param", one.param_words, "adapter parameter NAME=VALUE (repeatable)");
  app.add_option("--model", one.model_spec, "model cloud: shape name, real pair name or file");
  app.add_option("--query", one.query_spec, "query cloud: shape, real pair (its raw query scan + initial pose) or file");
  app.add_option("--initial", one.initial_file, "initial pose: 4x4 row-major text file (default: the pair's, or identity)");
  app.add_option("--max-dist", s.max_dist.start_m, "maximal correspondence distance in m (start of the schedule)")
      ->capture_default_str();
  app.add_option("--max-dist-factor", s.max_dist.factor, "multiply the maximal distance by this each iteration (1 = fixed)")
      ->capture_default_str();
  app.add_option("--min-max-dist", s.max_dist.floor_m, "the maximal distance never shrinks below this (m)");
  app.add_option("--iterations", s.max_iterations,
                 "iteration limit (1 to " + std::to_string(icp::kMaxIterations) + ")")
      ->capture_default_str();
  app.add_option("--min-step-m", s.min_translation_step_m, "converged when a step moves less than this (m) ...")
      ->capture_default_str();
  app.add_option("--min-step-rad", s.min_rotation_step_rad, "... and turns less than this (rad)")->capture_default_str();
  app.add_option("--query-stride", s.query_stride, "use every N-th query point")->capture_default_str();
  app.add_flag_callback("--no-hints", [&s] { s.hints = false; },
                        "search without the previous neighbours as hints (adapters that use hints; same answers, slower)");
  app.add_flag("--track", s.track,
               "keep each query's neighbour while it moves less than its margin, search the others for two (any adapter; same answers)");
  app.add_option("--threads", experiment.threads,
                 "threads each search may use (default: the experiment's, else 1; adapters that cannot share an index "
                 "use one, and each record says how many it used)")
      ->check(CLI::Range(1, nnb::SearchIndex::kMaxThreads));
  app.add_option("--data-dir", one.data.data_dir, nnb::cli::kDataDirHelp)->check(CLI::ExistingDirectory);
  app.add_option("--points", one.data.synthetic_points, "points per synthetic set")->capture_default_str();
  app.add_option("--seed", one.data.seed, "seed of the synthetic sets")->capture_default_str();
  app.add_option("--out", one.out_path, "results file (JSON, Google Benchmark schema), written atomically");
}

int run_single(const SingleRun& one) {
  if (one.adapter.empty() || one.model_spec.empty() || one.query_spec.empty() || one.out_path.empty()) {
    throw InputError("give --adapter, --model, --query and --out (or --experiment NAME)");
  }
  const icp::Settings& s = one.settings;
  if (s.query_stride < 1) throw InputError("--query-stride must be at least 1");
  nnb::files::check_output_path(one.out_path, {one.model_spec, one.query_spec, one.initial_file});
  const nnb::files::OutputLock lock(one.out_path);
  Input in = load_input(one.model_spec, one.query_spec, one.data, s.query_stride);
  if (!one.initial_file.empty()) {
    in.initial = ds::load_pose(one.initial_file, ds::PoseFormat::matrix4_row_major);
  }
  const auto rec = run_one(in, one.adapter, nnb::cli::parse_params(one.param_words), s,
                           icp::checked_rigid(in.initial, "the initial pose " + one.initial_file), 0);
  print_summary(std::cout, rec, true);
  nnb::files::write_file_atomically(
      one.out_path, icp::results_json(std::vector<icp::Record>{rec}, nnb::cli::build_type(), run_context("", one.data)));
  std::cout << "written " << one.out_path << "\n";
  return rec.result.failure.empty() ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  nnb::bench::mark_run_start(argc, argv);
  return nnb::cli::run_reporting_errors("run_icp", [&]() -> int {
    CLI::App app{"Point-to-point ICP (Besl and McKay) with any adapter as the nearest-neighbour search."};
    ExperimentFlags experiment;
    SingleRun one;
    add_flags(app, experiment, one);
    if (const auto code = nnb::cli::parse_command_line(app, argc, argv, "run_icp")) return *code;
    nnb::cli::warn_if_not_release(std::cerr);
    if (experiment.threads) one.settings.threads = *experiment.threads;
    if (!experiment.name.empty()) {
      if (!one.adapter.empty() || !one.model_spec.empty() || !one.query_spec.empty()) {
        throw InputError("--experiment takes its adapters and pairs from the file: drop --adapter/--model/--query");
      }
      experiment.out = one.out_path;
      return run_experiment(experiment, one.data);
    }
    if (experiment.resume || experiment.plan || !experiment.shard.empty()) {
      throw InputError("--resume, --shard and --plan run an experiment: give --experiment NAME");
    }
    return run_single(one);
  });
}
