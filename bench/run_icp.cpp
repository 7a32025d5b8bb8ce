// run_icp: point-to-point ICP of a query cloud onto a model cloud with any adapter as the
// nearest-neighbour search, or a whole ICP experiment (bench/experiments/icp_*.json).
#include "cli_common.hpp"
#include "machine.hpp"
#include "progress.hpp"
#include "icp.hpp"
#include "icp_experiment.hpp"
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
#include <sstream>

#include <unistd.h>

namespace {

namespace ds = nnb::datasets;
namespace icp = nnb::icp;
using nnb::InputError;

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

icp::Options options_of(const icp::Settings& s, const Eigen::Matrix4d& initial) {
  icp::Options o;
  o.initial_pose = initial;
  o.max_dist = s.max_dist;
  o.max_iterations = s.max_iterations;
  o.min_translation_step_m = s.min_translation_step_m;
  o.min_rotation_step_rad = s.min_rotation_step_rad;
  return o;
}

icp::Record run_one(const Input& in, const std::string& adapter, const nnb::Params& params, const icp::Options& options,
                    std::size_t query_stride, int repetition) {
  auto index = nnb::make_adapter(adapter, params);
  icp::Record rec;
  rec.pair = in.label;
  rec.adapter = adapter;
  rec.params = index->info().params;
  rec.bucket_param = bucket_param_of(index->info());
  if (const auto& bucket = index->info().bucket) rec.bucket_size = bucket->value;
  rec.model_points = static_cast<std::size_t>(in.model.cols());
  rec.query_points = static_cast<std::size_t>(in.query.cols());
  rec.query_stride = query_stride;
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
  return {experiment, data.data_dir.empty() ? ds::default_data_dir() : data.data_dir};
}

std::string experiment_path(const std::string& name) { return nnb::files::experiment_path(name, NNB_EXPERIMENTS_DIR); }

std::vector<std::string> adapters_of(const icp::Experiment& e) {
  std::vector<std::string> names = e.adapters.empty() ? nnb::adapter_names() : e.adapters;
  std::vector<std::string> chosen;
  for (const auto& name : names) {
    if (std::find(e.exclude.begin(), e.exclude.end(), name) != e.exclude.end()) continue;
    const auto it = e.params.find(name);
    auto index = nnb::make_adapter(name, it == e.params.end() ? nnb::Params{} : it->second);
    if (e.adapter_set == "with_bucket" && bucket_param_of(index->info()).empty()) continue;
    chosen.push_back(name);
  }
  return chosen;
}

int run_experiment(const std::string& name, std::string out_path, const ds::DataOptions& data) {
  const icp::Experiment e = icp::load_experiment(experiment_path(name));
  if (out_path.empty()) out_path = e.out;
  nnb::files::check_output_path(out_path, {experiment_path(name)});
  const nnb::files::OutputLock lock(out_path);
  nnb::files::remove_stale_temporaries(out_path);
  const auto adapters = adapters_of(e);
  std::cout << "experiment " << e.name << ": " << e.pairs.size() << " pair(s), adapters:";
  for (const auto& a : adapters) std::cout << " " << a;
  std::cout << "\nwriting " << out_path << "\n";
  std::vector<icp::Record> records;
  const std::size_t buckets_each = std::max<std::size_t>(1, e.bucket_sizes.size());
  nnb::bench::Progress progress(e.pairs.size() * adapters.size() * buckets_each * std::size_t(e.repetitions), 0,
                                isatty(STDERR_FILENO) != 0);
  for (const auto& pair : e.pairs) {
    const icp::Settings& s = icp::settings_for(e, pair);
    const Input in = load_input(pair, pair, data, s.query_stride);
    for (const auto& adapter : adapters) {
      nnb::Params base;
      if (const auto it = e.params.find(adapter); it != e.params.end()) base = it->second;
      const std::string bucket_param = bucket_param_of(nnb::make_adapter(adapter, base)->info());
      std::vector<std::optional<int>> buckets{std::nullopt};
      if (!e.bucket_sizes.empty() && !bucket_param.empty()) buckets.assign(e.bucket_sizes.begin(), e.bucket_sizes.end());
      for (const auto& bucket : buckets) {
        nnb::Params params = base;
        if (bucket) params[bucket_param] = std::to_string(*bucket);
        for (int rep = 0; rep < e.repetitions; ++rep) {
          icp::Record rec;
          progress.begin(pair + " " + adapter + (bucket ? " " + bucket_param + "=" + std::to_string(*bucket) : ""));
          try {
            rec = run_one(in, adapter, params, options_of(s, in.initial), s.query_stride, rep);
          } catch (const InputError& err) {  // e.g. a bucket size the library refuses
            std::cout << "skipped " << adapter << " " << bucket_param << "=" << (bucket ? *bucket : 0) << ": "
                      << err.what() << "\n";
            progress.end(std::size_t(e.repetitions - rep), std::string("skipped: ") + err.what());
            break;
          }
          progress.end(1, rec.result.failure.empty() ? "done" : rec.result.failure);
          print_summary(std::cout, rec, false);
          records.push_back(std::move(rec));
          nnb::files::write_file_atomically(out_path, icp::results_json(records, nnb::cli::build_type(),
                                                                      run_context(e.name, data)));
        }
      }
    }
  }
  progress.finish();
  std::cout << records.size() << " records written to " << out_path << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  nnb::bench::mark_run_start(argc, argv);
  return nnb::cli::run_reporting_errors("run_icp", [&]() -> int {
    CLI::App app{"Point-to-point ICP (Besl and McKay) with any adapter as the nearest-neighbour search."};
    std::string adapter, model_spec, query_spec, initial_file, out_path, experiment;
    std::vector<std::string> param_words;
    icp::Settings s;
    s.max_dist.start_m = 0.25;
    ds::DataOptions data;
    app.add_option("--experiment", experiment, "run an ICP experiment: a name in bench/experiments or a file");
    app.add_option("--adapter", adapter, "nearest-neighbour adapter (see nns_query --list)");
    app.add_option("--param", param_words, "adapter parameter NAME=VALUE (repeatable)");
    app.add_option("--model", model_spec, "model cloud: shape name, real pair name or file");
    app.add_option("--query", query_spec, "query cloud: shape, real pair (its raw query scan + initial pose) or file");
    app.add_option("--initial", initial_file, "initial pose: 4x4 row-major text file (default: the pair's, or identity)");
    app.add_option("--max-dist", s.max_dist.start_m, "maximal correspondence distance in m (start of the schedule)")
        ->capture_default_str();
    app.add_option("--max-dist-factor", s.max_dist.factor, "multiply the maximal distance by this each iteration (1 = fixed)")
        ->capture_default_str();
    app.add_option("--min-max-dist", s.max_dist.floor_m, "the maximal distance never shrinks below this (m)");
    app.add_option("--iterations", s.max_iterations, "iteration limit")->capture_default_str();
    app.add_option("--min-step-m", s.min_translation_step_m, "converged when a step moves less than this (m) ...")
        ->capture_default_str();
    app.add_option("--min-step-rad", s.min_rotation_step_rad, "... and turns less than this (rad)")->capture_default_str();
    app.add_option("--query-stride", s.query_stride, "use every N-th query point")->capture_default_str();
    app.add_option("--data-dir", data.data_dir, nnb::cli::kDataDirHelp);
    app.add_option("--points", data.synthetic_points, "points per synthetic set")->capture_default_str();
    app.add_option("--seed", data.seed, "seed of the synthetic sets")->capture_default_str();
    app.add_option("--out", out_path, "results file (JSON, Google Benchmark schema), written atomically");
    if (const auto code = nnb::cli::parse_command_line(app, argc, argv, "run_icp")) return *code;
    nnb::cli::warn_if_not_release(std::cerr);
    if (!experiment.empty()) {
      if (!adapter.empty() || !model_spec.empty() || !query_spec.empty()) {
        throw InputError("--experiment takes its adapters and pairs from the file: drop --adapter/--model/--query");
      }
      return run_experiment(experiment, out_path, data);
    }
    if (adapter.empty() || model_spec.empty() || query_spec.empty() || out_path.empty()) {
      throw InputError("give --adapter, --model, --query and --out (or --experiment NAME)");
    }
    if (s.query_stride < 1) throw InputError("--query-stride must be at least 1");
    nnb::files::check_output_path(out_path, {model_spec, query_spec, initial_file});
    const nnb::files::OutputLock lock(out_path);
    Input in = load_input(model_spec, query_spec, data, s.query_stride);
    if (!initial_file.empty()) {
      in.initial = ds::load_pose(initial_file, ds::PoseFormat::matrix4_row_major);
    }
    const auto rec = run_one(in, adapter, nnb::cli::parse_params(param_words),
                             options_of(s, icp::checked_rigid(in.initial, "the initial pose " + initial_file)),
                             s.query_stride, 0);
    print_summary(std::cout, rec, true);
    nnb::files::write_file_atomically(out_path, icp::results_json({rec}, nnb::cli::build_type(), run_context("", data)));
    std::cout << "written " << out_path << "\n";
    return rec.result.failure.empty() ? 0 : 3;
  });
}
