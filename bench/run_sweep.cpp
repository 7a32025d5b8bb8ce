// run_sweep: the experiment driver that reproduces the paper's sweeps (see bench/experiments/ and
// results/README.md). Exit codes: 0 done, 2 bad input (nothing written), 1 other failure.
#include "sweep/experiment.hpp"
#include "machine.hpp"
#include "progress.hpp"
#include "sweep/results_file.hpp"
#include "sweep/runner.hpp"
#include "sweep/shard.hpp"

#include "cli_common.hpp"
#include "files.hpp"
#include "nnb/registry.hpp"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>

namespace {

using namespace nnb::sweep;
using nnb::bench::read_build_info;
using nnb::bench::read_machine_info;

struct Flags {
  std::string experiment = "quick";
  std::string adapters, datasets, dists, out, data_dir, strategies;
  std::optional<int> repetitions;
  std::optional<int> rounds;
  std::optional<double> budget_s;
  std::optional<double> min_time_s;
  std::optional<int> threads;
  std::optional<std::size_t> points;
  std::optional<double> memory_limit_gib;
  std::optional<double> cell_timeout_s;
  bool resume = false;
  std::string shard;
  bool plan = false, plan_json = false;
  bool retry_failed = false;
};

Experiment configure(const Flags& flags, const std::vector<std::string>& all_adapters, const std::string& source_dir) {
  Experiment e = load_experiment(nnb::files::experiment_path(flags.experiment, source_dir + "/bench/experiments"), all_adapters);
  if (!flags.adapters.empty()) {
    e.adapters = split_list(flags.adapters);
    if (e.adapters.empty()) throw nnb::InputError("--adapters: no adapter given");
  }
  if (!flags.datasets.empty()) e.pairs = parse_datasets(flags.datasets);
  if (!flags.dists.empty()) e.dists = parse_dists(flags.dists);
  if (!flags.strategies.empty()) e.every_strategy = parse_strategies(flags.strategies);
  if (flags.repetitions) e.repetitions = *flags.repetitions;
  if (flags.rounds) e.rounds = *flags.rounds;
  if (flags.budget_s) e.budget_s = *flags.budget_s;
  if (flags.min_time_s) e.min_time_s = *flags.min_time_s;
  if (flags.threads) e.threads = *flags.threads;
  if (flags.points) e.synthetic_points = *flags.points;
  if (flags.memory_limit_gib) e.memory_limit_gib = *flags.memory_limit_gib;
  if (flags.cell_timeout_s) e.cell_timeout_s = *flags.cell_timeout_s;
  validate(e, all_adapters);
  return e;
}

// Files the run reads, which its output must never replace.
std::vector<std::string> input_files(const LoadedData& data, const Experiment& experiment) {
  std::vector<std::string> files{experiment.file};
  for (const auto* role : {&data.models, &data.queries}) {
    for (const auto& [spec, cloud] : *role) {
      if (cloud.kind == "file") files.push_back(cloud.source);
    }
  }
  return files;
}

// The same command line with --resume, quoted for a POSIX shell.
std::string resume_command() {
  const std::string command = nnb::bench::read_run_info().command_line;
  return command.find("'--resume'") == std::string::npos ? command + " --resume" : command;
}

void add_flags(CLI::App& app, Flags& flags) {
  app.add_option("--experiment", flags.experiment, "experiment name in bench/experiments/ or a JSON file")
      ->capture_default_str();
  app.add_option("--adapters", flags.adapters, "comma-separated adapters (default: the experiment's)");
  app.add_option("--datasets", flags.datasets, "comma-separated data sets: NAME (model = query) or MODEL:QUERY");
  app.add_option("--dists", flags.dists, "swept maximal distances, start:stop:step in metres");
  app.add_option("--strategies", flags.strategies,
                 "ranged search with each adapter's default strategy ('default') or every one it offers ('all')");
  app.add_option("--repetitions", flags.repetitions, "timed calls per cell at most, 1 to 10000 (each is a record)");
  app.add_option("--rounds", flags.rounds,
                 "passes over each model's units, each timing every cell that ran again (--repetitions calls a "
                 "pass), so that a cell's calls lie apart in time; a model's passes end before the next model's "
                 "(default 1)");
  app.add_option("--min-time", flags.min_time_s,
                 "repeat a cell until its calls took this many seconds in total, up to --repetitions (0: always all)");
  app.add_option("--threads", flags.threads,
                 "threads a search call may use (default 1; adapters that cannot share an index use one, "
                 "and each record says how many it used)")
      ->check(CLI::Range(1, nnb::SearchIndex::kMaxThreads));
  app.add_option("--budget", flags.budget_s, "seconds per call above which larger distances are skipped");
  app.add_option("--points", flags.points, "points per synthetic data set (the paper: 60000)");
  app.add_option("--memory-limit-gib", flags.memory_limit_gib,
                 "memory per build (index or peak RSS growth) above which larger models are skipped (default 8)");
  app.add_option("--out", flags.out, "results file (default: results/sweep_<experiment>.json, from the current folder)");
  app.add_option("--data-dir", flags.data_dir, nnb::cli::kDataDirHelp)->check(CLI::ExistingDirectory);
  app.add_flag("--resume", flags.resume, "finish the cells missing from --out (same configuration only)");
  app.add_option("--shard", flags.shard, "I/N: run only shard I (from 0) of N, balanced by expected cost");
  app.add_flag("--plan", flags.plan, "print the cells, units and shards with their expected cost; run nothing");
  app.add_flag("--json", flags.plan_json, "with --plan: print the plan as JSON");
  app.add_flag("--retry-failed", flags.retry_failed,
               "with --resume: run again the cells whose library crashed or timed out");
  app.add_option("--cell-timeout", flags.cell_timeout_s,
                 "seconds without a finished cell after which a library is killed and its cells recorded failed "
                 "(default 1800)");
}

void report_disagreements(const std::vector<Record>& records, std::size_t in_this_run, const std::string& out) {
  std::size_t total = 0;
  for (const auto& r : records) total += r.agrees && !*r.agrees;
  if (total == 0) return;
  std::cerr << "run_sweep: !!! " << total << " DISAGREEMENTS between exact adapters (" << in_this_run
            << " in this run): see the records with \"agrees\": false in " << out << "\n";
}

// Plans the experiment, then runs the cells not yet in the results file (or prints the plan).
int sweep(const Flags& flags, const BuildInfo& build) {
  const auto all_adapters = nnb::adapter_names();
  const Experiment experiment = configure(flags, all_adapters, build.source_dir);
  const ShardSpec shard = flags.shard.empty() ? ShardSpec{} : parse_shard(flags.shard);
  const std::string out = flags.out.empty() ? shard_path("results/sweep_" + experiment.name + ".json", shard) : flags.out;
  const LoadedData data = load_data(experiment, flags.data_dir);
  const auto adapters = plan_adapters(experiment);
  const SweepPlan plan(experiment, adapters);
  const ShardPlan shards = plan_shards(plan, data, shard.count);
  if (flags.plan) {
    print_plan(std::cout, shards, experiment, shard, flags.plan_json);
    return 0;
  }
  nnb::files::check_output_path(out, input_files(data, experiment));
  const nnb::files::OutputLock lock(out);
  nnb::files::remove_stale_temporaries(out);
  nnb::files::catch_interrupts();
  const UnitFilter in_shard = shard.given ? shards.filter(shard.index) : UnitFilter{};
  ResultsFile results(out, {&experiment, &adapters, &data, read_machine_info(), build, shard_config_json(shard),
                            shard_context_json(shards, shard)});
  if (flags.resume) {
    if (!results.resume(flags.retry_failed)) std::cerr << "run_sweep: --resume: " << out << " does not exist yet, starting afresh\n";
  } else if (std::filesystem::exists(out)) {
    std::cerr << "run_sweep: note: replacing " << out << " at the first checkpoint (--resume continues it)\n";
  }
  if (const char* abort_after = std::getenv("NNB_SWEEP_ABORT_AFTER_CELLS")) {
    results.abort_after(static_cast<std::size_t>(std::atol(abort_after)));
  }

  const auto planned = plan.cell_names(in_shard);
  std::size_t already = 0, rounds_done = 0;
  for (const auto& name : planned) {
    const Record* r = results.find(name);
    already += r != nullptr;
    if (r) rounds_done += rounds_counted(*r, experiment);
  }
  std::cerr << "run_sweep: experiment '" << experiment.name << "'"
            << (shard.given ? ", shard " + flags.shard : std::string()) << ": " << planned.size() << " cells ("
            << already << " already in " << out << "), " << adapters.size() << " adapters, "
            << experiment.pairs.size() << " model/query pairs, " << experiment.dists.values().size()
            << " distances, " << experiment.repetitions << " repetitions"
            << (experiment.rounds > 1 ? " in each of " + std::to_string(experiment.rounds) + " rounds" : std::string())
            << ", budget " << experiment.budget_s << " s"
            << (experiment.skip_larger_models ? " (also for larger models)" : "") << ", memory limit "
            << experiment.memory_limit_gib << " GiB\n";

  const std::size_t rounds = static_cast<std::size_t>(experiment.rounds);
  Progress progress(planned.size() * rounds, rounds_done, isatty(STDERR_FILENO) != 0);
  const std::size_t disagreements =
      run_experiment(experiment, data, plan, results.records(), results, progress, in_shard);
  progress.finish();
  results.write();  // also when every cell was already there

  report_disagreements(results.records(), disagreements, out);
  std::cerr << "run_sweep: wrote " << results.records().size() << " cells to " << out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  nnb::bench::mark_run_start(argc, argv);
  CLI::App app{"Sweeps the maximal distance for every adapter, data set and query kind; writes JSON results."};
  Flags flags;
  add_flags(app, flags);
  if (const auto code = nnb::cli::parse_command_line(app, argc, argv, "run_sweep")) return *code;
  nnb::cli::warn_if_not_release(std::cerr);
  const BuildInfo build = read_build_info();
  try {
    return sweep(flags, build);
  } catch (const Interrupted& e) {
    std::cerr << "run_sweep: " << e.what() << "; finish with: " << resume_command() << "\n";
    return 128 + nnb::files::interrupted();
  } catch (const nnb::InputError& e) {
    std::cerr << "run_sweep: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "run_sweep: failed: " << e.what() << "\n";
    return 1;
  }
}
