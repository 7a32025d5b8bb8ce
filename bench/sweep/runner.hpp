#pragma once
// Runs an experiment cell by cell: builds each (model, adapter) index once, sweeps the distances,
// applies the time and neighbour budgets, and cross-checks exact adapters.
#include "experiment.hpp"
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

/// An adapter of the run and the query kinds it is swept with: ranged always; knn and radius
/// when the library offers them (strategy native or via_box), as in the paper.
struct PlannedAdapter {
  std::string name;
  AdapterInfo info;
  std::vector<SearchKind> kinds;
  std::vector<Strategy> ranged_strategies;  ///< the default first; empty when ranged search is not run
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
  virtual bool has(const std::string& name) const = 0;
  /// Records and checkpoints a batch of cells.
  virtual void add(const std::vector<Record>& batch) = 0;
};

/// Which (model, adapter) units a run takes on (a shard, see shard.hpp); empty: all of them.
using UnitFilter = std::function<bool(const std::string& model, const std::string& adapter)>;

/// Resolves every model and query of the experiment (real scans from data_dir, empty = the default lookup);
/// throws InputError for a bad name or file.
LoadedData load_data(const Experiment& experiment, const std::string& data_dir);
/// The adapters of the experiment with their info and swept kinds.
std::vector<PlannedAdapter> plan_adapters(const Experiment& experiment);
/// Every cell name the experiment will record (construction records included), in run order.
std::vector<std::string> planned_cells(const Experiment& experiment, const std::vector<PlannedAdapter>& adapters,
                                       const UnitFilter& in_shard = {});

/// Runs every cell the sink does not have yet; previous: records already in the sink (reference values
/// for the cross-check). Returns the number of disagreements found in this run.
std::size_t run_experiment(const Experiment& experiment, const LoadedData& data,
                           const std::vector<PlannedAdapter>& adapters, const std::vector<Record>& previous,
                           ResultsSink& sink, Progress& progress, const UnitFilter& in_shard = {});

}  // namespace nnb::sweep
