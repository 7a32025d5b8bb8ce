#pragma once
// Shards of a run, for a cluster's job array: the run's units (run_sweep: a (model, adapter) index and its
// cells; run_icp: a (pair, adapter, bucket) setting and its repetitions) are split into N shards of about
// equal expected cost, the same way by every task, so that each task runs its shard into a file of its own
// and plots/merge_results.py joins them. The rule is generic over the unit type and header-only, so that
// both programs use this one copy; what is run_sweep's own is declared at the end.
#include "experiment.hpp"

#include "nnb/cloud.hpp"

#include <algorithm>
#include <cstddef>
#include <functional>
#include <iomanip>
#include <iosfwd>
#include <numeric>
#include <ostream>
#include <sstream>
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

namespace shard_detail {

inline int parse_whole(const std::string& text, const std::string& what) {
  if (text.empty() || text.size() > 6 || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    throw InputError("--shard: " + what + " '" + text + "' is not a whole number");
  }
  return std::stoi(text);
}

inline std::string fixed(double value, int decimals) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value;
  return out.str();
}

}  // namespace shard_detail

/// Parses "I/N" with 0 <= I < N <= kMaxShards; throws InputError otherwise.
inline ShardSpec parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  if (slash == std::string::npos) throw InputError("--shard: '" + text + "' is not I/N (e.g. 0/4)");
  ShardSpec shard{shard_detail::parse_whole(text.substr(0, slash), "index"),
                  shard_detail::parse_whole(text.substr(slash + 1), "count"), true};
  if (shard.count < 1 || shard.count > kMaxShards) {
    throw InputError("--shard: the count must be 1 to " + std::to_string(kMaxShards) + ", not " +
                     std::to_string(shard.count));
  }
  if (shard.index >= shard.count) {
    throw InputError("--shard: index " + std::to_string(shard.index) + " is not below the count " +
                     std::to_string(shard.count) + " (shards are numbered from 0)");
  }
  return shard;
}

/// "I/N".
inline std::string shard_label(const ShardSpec& shard) {
  return std::to_string(shard.index) + "/" + std::to_string(shard.count);
}

/// The default results file of a shard: "results/sweep_x.json" becomes "results/sweep_x.shard-I-of-N.json".
inline std::string shard_path(const std::string& path, const ShardSpec& shard) {
  if (!shard.given) return path;
  const std::string tag = ".shard-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count);
  const std::string ext = ".json";
  const bool has_ext = path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
  return has_ext ? path.substr(0, path.size() - ext.size()) + tag + ext : path + tag;
}

/// How much slower than a typical k-d tree an adapter is expected to be per search (libspatialindex,
/// brute force, ITK's tree, hnswlib's graph, ALGLIB's tree, OpenVDB's grid and CGAL are the slow ones); 1 for
/// the rest.
inline double adapter_cost_factor(const std::string& adapter) {
  // From the reference runs: libspatialindex takes seconds to minutes a call where a k-d tree takes a
  // tenth of a second; brute force about fifty times a k-d tree at 60,000 points. ITK's tree and hnswlib's
  // graph, ALGLIB's tree, OpenVDB's grid: the median over the real pairs of their ranged 1-NN time over Debian
  // nanoflann's, 7.8x, 8.7x, 4.7x and 4.4x (summary.txt in results/ab/itk_kdtree/, hnswlib/, alglib_kdtree/,
  // openvdb_pointindex/).
  if (adapter.rfind("spatialindex_", 0) == 0) return 200.0;
  if (adapter == "brute_force") return 50.0;
  if (adapter == "itk_kdtree" || adapter == "hnswlib_hnsw") return 8.0;
  if (adapter == "alglib_kdtree") return 5.0;
  if (adapter == "openvdb_pointindex") return 4.0;
  if (adapter.rfind("cgal", 0) == 0) return 2.0;
  return 1.0;
}

/// The cost factors of the slow adapters, for a plan's legend.
inline std::string adapter_cost_factors_text() {
  return "brute_force " + shard_detail::fixed(adapter_cost_factor("brute_force"), 0) + ", spatialindex_* " +
         shard_detail::fixed(adapter_cost_factor("spatialindex_rstar"), 0) + ", itk_kdtree and hnswlib_hnsw " +
         shard_detail::fixed(adapter_cost_factor("itk_kdtree"), 0) + ", alglib_kdtree " +
         shard_detail::fixed(adapter_cost_factor("alglib_kdtree"), 0) + ", openvdb_pointindex " +
         shard_detail::fixed(adapter_cost_factor("openvdb_pointindex"), 0) + ", cgal_kdtree " +
         shard_detail::fixed(adapter_cost_factor("cgal_kdtree"), 0) + ", others 1";
}

/// What --shard adds to context.config, as JSON text ({"index":I,"count":N}): a resume as another shard is
/// refused. Empty when not sharded.
inline std::string shard_config_json(const ShardSpec& shard) {
  if (!shard.given) return "";
  return "{\"index\":" + std::to_string(shard.index) + ",\"count\":" + std::to_string(shard.count) + "}";
}

/// A plan over any unit type with `cells` (the unit's cell names, in run order), `cost` (expected, in the
/// program's own unit) and `shard` (set by assign_longest_first).
template <class Unit>
struct BasicShardPlan {
  int count = 1;
  std::size_t total_cells = 0;
  std::vector<Unit> units;          ///< in run order
  std::vector<double> shard_cost;   ///< per shard
  std::vector<std::size_t> shard_cells;

  /// The cell names of one shard, in run order.
  std::vector<std::string> cells_of(int shard) const {
    std::vector<std::string> cells;
    for (const auto& u : units) {
      if (u.shard == shard) cells.insert(cells.end(), u.cells.begin(), u.cells.end());
    }
    return cells;
  }
  /// How many units one shard runs.
  std::size_t units_in(int shard) const {
    return static_cast<std::size_t>(
        std::count_if(units.begin(), units.end(), [&](const Unit& u) { return u.shard == shard; }));
  }
  /// The largest single unit's cost: no split can end sooner.
  double largest_unit() const {
    double largest = 0.0;
    for (const auto& u : units) largest = std::max(largest, u.cost);
    return largest;
  }
};

/// Splits the plan's units into plan.count shards: longest expected cost first, each to the shard with the
/// least cost so far (the lowest index on a tie), which is within 4/3 of the best makespan. Deterministic:
/// the same units in the same order give the same shards in every task.
template <class Unit>
void assign_longest_first(BasicShardPlan<Unit>& plan) {
  std::vector<std::size_t> order(plan.units.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return plan.units[a].cost > plan.units[b].cost; });
  plan.shard_cost.assign(plan.count, 0.0);
  plan.shard_cells.assign(plan.count, 0);
  plan.total_cells = 0;
  for (std::size_t u : order) {
    const auto least = std::min_element(plan.shard_cost.begin(), plan.shard_cost.end());
    const int shard = static_cast<int>(least - plan.shard_cost.begin());
    plan.units[u].shard = shard;
    plan.shard_cost[shard] += plan.units[u].cost;
    plan.shard_cells[shard] += plan.units[u].cells.size();
    plan.total_cells += plan.units[u].cells.size();
  }
}

/// The plan's shards as a text table (units, cells, cost and share of each, the chosen shard marked) and
/// how well they are balanced.
template <class Unit>
void print_shard_table(std::ostream& out, const BasicShardPlan<Unit>& plan, const ShardSpec& shard) {
  using shard_detail::fixed;
  const double total = std::accumulate(plan.shard_cost.begin(), plan.shard_cost.end(), 0.0);
  const double mean = total / plan.count;
  const double largest = *std::max_element(plan.shard_cost.begin(), plan.shard_cost.end());
  out << "shard  units   cells        cost  share\n";
  for (int s = 0; s < plan.count; ++s) {
    out << std::setw(5) << s << std::setw(7) << plan.units_in(s) << std::setw(8) << plan.shard_cells[s] << std::setw(12)
        << fixed(plan.shard_cost[s], 1) << std::setw(6) << fixed(total > 0 ? 100.0 * plan.shard_cost[s] / total : 0, 1)
        << "%" << (shard.given && s == shard.index ? "  <- this shard" : "") << "\n";
  }
  out << "balance: largest shard " << fixed(largest, 1) << " = " << fixed(mean > 0 ? largest / mean : 1, 2)
      << " x the mean " << fixed(mean, 1) << "; no plan can go below the largest unit, "
      << fixed(plan.largest_unit(), 1) << "\n";
}

// ---- run_sweep's units ----

class SweepPlan;
struct LoadedData;
/// As in plan.hpp: which (model, adapter) units a run takes on.
using UnitFilter = std::function<bool(const std::string& model, const std::string& adapter)>;

/// One (model, adapter) unit: its cells (the build record included), expected cost and shard.
struct ShardUnit {
  std::string model;
  std::string adapter;
  std::vector<std::string> cells;
  double cost = 0.0;  ///< model points x query points x cells x adapter factor, in 1e9
  int shard = 0;
};

struct ShardPlan : BasicShardPlan<ShardUnit> {
  /// The units of one shard, as run_experiment's filter.
  UnitFilter filter(int shard) const;
};

/// Splits the plan's units into count shards (assign_longest_first). Deterministic for the same
/// experiment and data.
ShardPlan plan_shards(const SweepPlan& plan, const LoadedData& data, int count);

/// The plan as text (a table of shards; the units of the chosen shard when one is given) or JSON.
void print_plan(std::ostream& out, const ShardPlan& plan, const Experiment& experiment, const ShardSpec& shard,
                bool as_json);

/// What a shard puts in context as "shard" (the spec, the plan summary and the shard's cells), as JSON
/// text; empty when not sharded.
std::string shard_context_json(const ShardPlan& plan, const ShardSpec& shard);

}  // namespace nnb::sweep
