#pragma once
// Runs an experiment cell by cell: builds each (model, adapter) index once, sweeps the distances,
// applies the time and neighbour budgets, and cross-checks exact adapters.
#include "experiment.hpp"
#include "plan.hpp"
#include "progress.hpp"
#include "record.hpp"

#include "nnb/datasets/catalog.hpp"
#include "nnb/search_index.hpp"

#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace nnb::sweep {

using bench::Progress;

/// The clouds of an experiment, resolved once: by spec, as model and as query.
struct LoadedData {
  std::map<std::string, datasets::NamedCloud> models;
  std::map<std::string, datasets::NamedCloud> queries;
};

/// Thrown by a sink once SIGINT or SIGTERM has arrived and the checkpoint holding every finished cell is
/// written: the run stops there and --resume continues it.
struct Interrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Where finished cells go; add() is a checkpoint (the batch lands in the file together).
class ResultsSink {
 public:
  virtual ~ResultsSink() = default;
  /// Whether a cell of that name is already recorded (resume).
  bool has(const std::string& name) const { return find(name) != nullptr; }
  /// The cell of that name as recorded, or null.
  virtual const Record* find(const std::string& name) const = 0;
  /// Records and checkpoints a batch of cells; a cell already recorded is replaced only by one of more
  /// rounds (its next round's repetitions added).
  virtual void add(const std::vector<Record>& batch) = 0;
};

/// Whether the cell will not run again: skipped, or a call over the budget ended its rounds.
bool settled(const Record& r, const Experiment& e);
/// Progress counts a cell once a round. What a run counts at its start for a recorded cell: a settled one in
/// full (its later rounds cost nothing: counted as a resumed run passes them, they would read as work done in
/// its first seconds and make its ETA far too short), else its rounds so far.
std::size_t rounds_counted(const Record& r, const Experiment& e);
/// Whether a later round counts a cell that settled during the run without running it: skipped, or ended by
/// the budget in an earlier round (one ended in round 2 was counted there).
bool settled_in_round(const Record& r, int round, const Experiment& e);

/// Resolves every model and query of the experiment (real scans from data_dir, empty = the default lookup);
/// throws InputError for a bad name or file.
LoadedData load_data(const Experiment& experiment, const std::string& data_dir);

/// Runs every cell of the plan's units (those in_shard takes) the sink does not have yet, unit by unit:
/// the index built and timed, each series swept up to its budget, every cell cross-checked and recorded.
/// previous: records already in the sink (reference values for the cross-check). Returns the number of
/// disagreements found in this run.
std::size_t run_experiment(const Experiment& experiment, const LoadedData& data, const SweepPlan& plan,
                           const std::vector<Record>& previous, ResultsSink& sink, Progress& progress,
                           const UnitFilter& in_shard = {});

}  // namespace nnb::sweep
