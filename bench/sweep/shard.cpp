// run_sweep's units: (model, adapter) pairs, their cost, the plan as text and JSON.
#include "shard.hpp"

#include "runner.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <ostream>
#include <set>

namespace nnb::sweep {

using nlohmann::ordered_json;

namespace {

// Every pair of a unit has the same cells (they depend on the adapter and the experiment only), so the
// sweep cells split evenly over the pairs; the build counts as one cell of the model's own size.
double unit_cost(const ShardUnit& unit, const std::vector<PairWork>& pairs, const LoadedData& data) {
  const double model_points = static_cast<double>(data.models.at(unit.model).points.cols());
  const double cells_per_pair = static_cast<double>(unit.cells.size() - 1) / static_cast<double>(pairs.size());
  double work = model_points * model_points;
  for (const auto& [pair, groups] : pairs) {
    work += model_points * static_cast<double>(data.queries.at(pair->query).points.cols()) * cells_per_pair;
  }
  return adapter_cost_factor(unit.adapter) * work * 1e-9;
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
  out << "plan: experiment '" << e.name << "': " << plan.total_cells << " cells in " << plan.units.size()
      << " units (model x adapter, one index each) over " << plan.count << " shards\n"
      << "expected cost: model points x query points x cells x adapter factor (" << adapter_cost_factors_text()
      << "), in 1e9\n";
  print_shard_table(out, plan, shard);
  if (!shard.given) return;
  out << "units of shard " << shard_label(shard) << ":\n";
  for (const auto& u : plan.units) {
    if (u.shard == shard.index) out << "  " << u.model << " " << u.adapter << ": " << u.cells.size() << " cells, cost "
                                    << shard_detail::fixed(u.cost, 1) << "\n";
  }
}

}  // namespace

UnitFilter ShardPlan::filter(int shard) const {
  std::set<std::pair<std::string, std::string>> mine;
  for (const auto& u : units) {
    if (u.shard == shard) mine.emplace(u.model, u.adapter);
  }
  return [mine](const std::string& model, const std::string& adapter) { return mine.count({model, adapter}) > 0; };
}

ShardPlan plan_shards(const SweepPlan& sweep, const LoadedData& data, int count) {
  ShardPlan plan;
  plan.count = count;
  plan.total_cells = sweep.cell_names().size();
  for (const auto& planned : sweep.units()) {
    ShardUnit unit{planned.model, planned.adapter->name, planned.cell_names(), 0.0, 0};
    unit.cost = unit_cost(unit, planned.work, data);
    plan.units.push_back(std::move(unit));
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

std::string shard_context_json(const ShardPlan& plan, const ShardSpec& shard) {
  if (!shard.given) return "";
  ordered_json j{{"index", shard.index}, {"count", shard.count}, {"plan_cells", plan.total_cells},
                 {"plan_units", plan.units.size()}, {"cells", plan.cells_of(shard.index)}, {"units", units_json(plan)}};
  return j.dump();
}

}  // namespace nnb::sweep
