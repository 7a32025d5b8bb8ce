#pragma once
// The sweep's plan, made once from the experiment: its (model, adapter) units in run order, each with the
// groups of cells it sweeps, every cell named. The runner, --resume, the progress bar and the shards read it.
#include "experiment.hpp"

#include "nnb/search_index.hpp"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace nnb::sweep {

/// An adapter of the run and the query kinds it is swept with: ranged always; knn and radius
/// when the library offers them (strategy native or via_box), as in the paper.
struct PlannedAdapter {
  std::string name;
  AdapterInfo info;
  std::vector<SearchKind> kinds;
  std::vector<Strategy> ranged_strategies;  ///< the default first; empty when ranged search is not run
};

/// One cell: a search at one maximal distance (none for knn).
struct Cell {
  std::string name;
  std::optional<double> max_dist_m;
  std::string dist_label;  ///< the distance as in the name, "" for knn
};

/// A (kind, strategy, k) series, swept over the distances in increasing order.
struct Group {
  SearchKind kind;
  Strategy strategy;
  std::optional<int> k;
  std::vector<Cell> cells;
};

/// The series a unit sweeps on one of its model's pairs.
struct PairWork {
  const DataPair* pair;
  std::vector<Group> groups;
};

/// One index and its cells: built once, swept, and isolated together.
struct PlanUnit {
  std::string model;  ///< the model's spec
  const PlannedAdapter* adapter;
  std::string build;  ///< the construction record's name
  std::vector<PairWork> work;
  /// The build's name, then every cell's, in run order.
  std::vector<std::string> cell_names() const;
};

/// Which (model, adapter) units a run takes on (a shard, see shard.hpp); empty: all of them.
using UnitFilter = std::function<bool(const std::string& model, const std::string& adapter)>;

class SweepPlan {
 public:
  /// Every unit of the experiment: its models in order of first appearance, each with every adapter.
  /// InputError when two cells would share a name. Keeps pointers into experiment and adapters.
  SweepPlan(const Experiment& experiment, const std::vector<PlannedAdapter>& adapters);
  const std::vector<PlanUnit>& units() const { return units_; }
  /// Every record name of the units in_shard takes (all when empty), in run order.
  std::vector<std::string> cell_names(const UnitFilter& in_shard = {}) const;

 private:
  std::vector<PlanUnit> units_;
};

/// The adapters of the experiment with their info and swept kinds.
std::vector<PlannedAdapter> plan_adapters(const Experiment& experiment);

}  // namespace nnb::sweep
