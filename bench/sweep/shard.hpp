#pragma once
// Shards of a sweep, for a cluster's job array: the (model, adapter) units (one index, built once, and its
// cells) are split into N shards of about equal expected cost, the same way by every task, so that each
// task runs its shard into a file of its own and plots/merge_results.py joins them.
#include "experiment.hpp"
#include "runner.hpp"

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace nnb::sweep {

/// --shard I/N: this run is shard I (0-based) of N. Not given: the whole run, one shard.
struct ShardSpec {
  int index = 0;
  int count = 1;
  bool given = false;
};

/// More shards than this is a mistyped number.
constexpr int kMaxShards = 100000;

/// Parses "I/N" with 0 <= I < N <= kMaxShards; throws InputError otherwise.
ShardSpec parse_shard(const std::string& text);
/// The default results file of a shard: "results/sweep_x.json" becomes "results/sweep_x.shard-I-of-N.json".
std::string shard_path(const std::string& path, const ShardSpec& shard);

/// One (model, adapter) unit: its cells (the build record included), expected cost and shard.
struct ShardUnit {
  std::string model;
  std::string adapter;
  std::vector<std::string> cells;
  double cost = 0.0;  ///< model points x query points x cells x adapter factor, in 1e9
  int shard = 0;
};

struct ShardPlan {
  int count = 1;
  std::size_t total_cells = 0;
  std::vector<ShardUnit> units;     ///< in run order
  std::vector<double> shard_cost;   ///< per shard
  std::vector<std::size_t> shard_cells;

  /// The units of one shard, as run_experiment's filter.
  UnitFilter filter(int shard) const;
  /// The cell names of one shard, in run order.
  std::vector<std::string> cells_of(int shard) const;
};

/// How much slower than a typical k-d tree an adapter is expected to be per cell (libspatialindex,
/// brute force and CGAL are the slow ones); 1 for the rest.
double adapter_cost_factor(const std::string& adapter);

/// Splits the experiment's units into count shards: longest expected cost first, each to the shard with
/// the least cost so far (the lowest index on a tie). Deterministic for the same experiment and data.
ShardPlan plan_shards(const Experiment& experiment, const std::vector<PlannedAdapter>& adapters,
                      const LoadedData& data, int count);

/// The plan as text (a table of shards; the units of the chosen shard when one is given) or JSON.
void print_plan(std::ostream& out, const ShardPlan& plan, const Experiment& experiment, const ShardSpec& shard,
                bool as_json);

/// What a shard adds to the results file: the spec joined to context.config (so a resume with another
/// shard is refused) and the plan summary put in context, as JSON texts; both empty when not sharded.
std::string shard_config_json(const ShardSpec& shard);
std::string shard_context_json(const ShardPlan& plan, const ShardSpec& shard);

}  // namespace nnb::sweep
