#include "shard.hpp"

#include "nnb/cloud.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <map>
#include <numeric>
#include <ostream>
#include <set>
#include <sstream>

namespace nnb::sweep {

using nlohmann::ordered_json;

namespace {

int parse_whole(const std::string& text, const std::string& what) {
  if (text.empty() || text.size() > 6 || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    throw InputError("--shard: " + what + " '" + text + "' is not a whole number");
  }
  return std::stoi(text);
}

std::string shard_label(const ShardSpec& shard) {
  return std::to_string(shard.index) + "/" + std::to_string(shard.count);
}

// Each distinct model and the pairs that use it, in the run's order (as runner.cpp visits them).
std::vector<std::pair<std::string, std::vector<const DataPair*>>> pairs_by_model(const Experiment& e) {
  std::vector<std::pair<std::string, std::vector<const DataPair*>>> models;
  for (const auto& pair : e.pairs) {
    auto it = std::find_if(models.begin(), models.end(), [&](const auto& m) { return m.first == pair.model; });
    if (it == models.end()) it = models.insert(models.end(), {pair.model, {}});
    it->second.push_back(&pair);
  }
  return models;
}

// Every pair of a unit has the same cells (they depend on the adapter and the experiment only), so the
// sweep cells split evenly over the pairs; the build counts as one cell of the model's own size.
double unit_cost(const ShardUnit& unit, const std::vector<const DataPair*>& pairs, const LoadedData& data) {
  const double model_points = static_cast<double>(data.models.at(unit.model).points.cols());
  const double cells_per_pair = static_cast<double>(unit.cells.size() - 1) / static_cast<double>(pairs.size());
  double work = model_points * model_points;
  for (const auto* pair : pairs) {
    work += model_points * static_cast<double>(data.queries.at(pair->query).points.cols()) * cells_per_pair;
  }
  return adapter_cost_factor(unit.adapter) * work * 1e-9;
}

// Longest processing time first onto the least loaded shard: within 4/3 of the best makespan.
void assign_longest_first(ShardPlan& plan) {
  std::vector<std::size_t> order(plan.units.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return plan.units[a].cost > plan.units[b].cost; });
  plan.shard_cost.assign(plan.count, 0.0);
  plan.shard_cells.assign(plan.count, 0);
  for (std::size_t u : order) {
    const auto least = std::min_element(plan.shard_cost.begin(), plan.shard_cost.end());
    const int shard = static_cast<int>(least - plan.shard_cost.begin());
    plan.units[u].shard = shard;
    plan.shard_cost[shard] += plan.units[u].cost;
    plan.shard_cells[shard] += plan.units[u].cells.size();
  }
}

std::string fixed(double value, int decimals) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value;
  return out.str();
}

ordered_json units_json(const ShardPlan& plan) {
  ordered_json units = ordered_json::array();
  for (const auto& u : plan.units) {
    units.push_back({{"model", u.model}, {"adapter", u.adapter}, {"cells", u.cells.size()}, {"cost", u.cost},
                     {"shard", u.shard}});
  }
  return units;
}

ordered_json plan_json(const ShardPlan& plan, const Experiment& e, const ShardSpec& shard) {
  ordered_json j{{"experiment", e.name}, {"shards", plan.count}, {"total_cells", plan.total_cells},
                 {"total_units", plan.units.size()}, {"cost_model", "model points x query points x cells x adapter "
                                                                    "factor, in 1e9"},
                 {"units", units_json(plan)}, {"shard_cost", plan.shard_cost}, {"shard_cells", plan.shard_cells}};
  if (shard.given) {
    j["shard"] = shard.index;
    j["cells"] = plan.cells_of(shard.index);
  }
  return j;
}

void print_plan_text(std::ostream& out, const ShardPlan& plan, const Experiment& e, const ShardSpec& shard) {
  const double total = std::accumulate(plan.shard_cost.begin(), plan.shard_cost.end(), 0.0);
  const double mean = total / plan.count;
  const double largest = *std::max_element(plan.shard_cost.begin(), plan.shard_cost.end());
  double largest_unit = 0.0;
  for (const auto& u : plan.units) largest_unit = std::max(largest_unit, u.cost);
  out << "plan: experiment '" << e.name << "': " << plan.total_cells << " cells in " << plan.units.size()
      << " units (model x adapter, one index each) over " << plan.count << " shards\n"
      << "expected cost: model points x query points x cells x adapter factor (brute_force "
      << adapter_cost_factor("brute_force") << ", spatialindex_* " << adapter_cost_factor("spatialindex_rstar")
      << ", cgal_kdtree " << adapter_cost_factor("cgal_kdtree") << ", others 1), in 1e9\n"
      << "shard  units   cells        cost  share\n";
  for (int s = 0; s < plan.count; ++s) {
    const auto units = std::count_if(plan.units.begin(), plan.units.end(), [&](const auto& u) { return u.shard == s; });
    out << std::setw(5) << s << std::setw(7) << units << std::setw(8) << plan.shard_cells[s] << std::setw(12)
        << fixed(plan.shard_cost[s], 1) << std::setw(6) << fixed(total > 0 ? 100.0 * plan.shard_cost[s] / total : 0, 1)
        << "%" << (shard.given && s == shard.index ? "  <- this shard" : "") << "\n";
  }
  out << "balance: largest shard " << fixed(largest, 1) << " = " << fixed(mean > 0 ? largest / mean : 1, 2)
      << " x the mean " << fixed(mean, 1) << "; no plan can go below the largest unit, " << fixed(largest_unit, 1)
      << "\n";
  if (!shard.given) return;
  out << "units of shard " << shard_label(shard) << ":\n";
  for (const auto& u : plan.units) {
    if (u.shard == shard.index) out << "  " << u.model << " " << u.adapter << ": " << u.cells.size() << " cells, cost "
                                    << fixed(u.cost, 1) << "\n";
  }
}

}  // namespace

ShardSpec parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  if (slash == std::string::npos) throw InputError("--shard: '" + text + "' is not I/N (e.g. 0/4)");
  ShardSpec shard{parse_whole(text.substr(0, slash), "index"), parse_whole(text.substr(slash + 1), "count"), true};
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

std::string shard_path(const std::string& path, const ShardSpec& shard) {
  if (!shard.given) return path;
  const std::string tag = ".shard-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count);
  const std::string ext = ".json";
  const bool has_ext = path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
  return has_ext ? path.substr(0, path.size() - ext.size()) + tag + ext : path + tag;
}

double adapter_cost_factor(const std::string& adapter) {
  // From the reference runs: libspatialindex takes seconds to minutes a call where a k-d tree takes a
  // tenth of a second; brute force about fifty times a k-d tree at 60,000 points.
  if (adapter.rfind("spatialindex_", 0) == 0) return 200.0;
  if (adapter == "brute_force") return 50.0;
  if (adapter.rfind("cgal", 0) == 0) return 2.0;
  return 1.0;
}

UnitFilter ShardPlan::filter(int shard) const {
  std::set<std::pair<std::string, std::string>> mine;
  for (const auto& u : units) {
    if (u.shard == shard) mine.emplace(u.model, u.adapter);
  }
  return [mine](const std::string& model, const std::string& adapter) { return mine.count({model, adapter}) > 0; };
}

std::vector<std::string> ShardPlan::cells_of(int shard) const {
  std::vector<std::string> cells;
  for (const auto& u : units) {
    if (u.shard == shard) cells.insert(cells.end(), u.cells.begin(), u.cells.end());
  }
  return cells;
}

ShardPlan plan_shards(const Experiment& e, const std::vector<PlannedAdapter>& adapters, const LoadedData& data,
                      int count) {
  ShardPlan plan;
  plan.count = count;
  plan.total_cells = planned_cells(e, adapters).size();  // also refuses cells that would share a name
  for (const auto& [model, pairs] : pairs_by_model(e)) {
    for (const auto& adapter : adapters) {
      ShardUnit unit{model, adapter.name, {}, 0.0, 0};
      const std::string& m = model;
      const std::string& a = adapter.name;
      unit.cells = planned_cells(e, adapters, [&](const std::string& um, const std::string& ua) {
        return um == m && ua == a;
      });
      unit.cost = unit_cost(unit, pairs, data);
      plan.units.push_back(std::move(unit));
    }
  }
  assign_longest_first(plan);
  return plan;
}

void print_plan(std::ostream& out, const ShardPlan& plan, const Experiment& e, const ShardSpec& shard, bool as_json) {
  if (as_json) {
    out << plan_json(plan, e, shard).dump(1) << "\n";
  } else {
    print_plan_text(out, plan, e, shard);
  }
}

std::string shard_config_json(const ShardSpec& shard) {
  if (!shard.given) return "";
  return ordered_json{{"index", shard.index}, {"count", shard.count}}.dump();
}

std::string shard_context_json(const ShardPlan& plan, const ShardSpec& shard) {
  if (!shard.given) return "";
  ordered_json j{{"index", shard.index}, {"count", shard.count}, {"plan_cells", plan.total_cells},
                 {"plan_units", plan.units.size()}, {"cells", plan.cells_of(shard.index)}, {"units", units_json(plan)}};
  return j.dump();
}

}  // namespace nnb::sweep
