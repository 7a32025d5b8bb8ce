// The plan: units, series and cell names, from the experiment alone (no data, no sink).
#include "plan.hpp"

#include "nnb/registry.hpp"

#include <algorithm>
#include <iomanip>
#include <set>
#include <sstream>

namespace nnb::sweep {
namespace {

// Cell names use the spec with '/' replaced, so that a file path stays one name component.
std::string name_component(const std::string& spec) {
  std::string label = spec;
  std::replace(label.begin(), label.end(), '/', '_');
  return label;
}

std::string format_dist(double value_m, int decimals) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value_m;
  return out.str();
}

// A ranged strategy other than the adapter's default gets its own component in the cell names.
std::string kind_component(SearchKind kind, Strategy strategy, const PlannedAdapter& adapter) {
  std::string text = std::string(to_string(kind)) + "/";
  if (kind == SearchKind::ranged && strategy != adapter.info.ranged) text += "strategy:" + std::string(to_string(strategy)) + "/";
  return text;
}

std::vector<Group> groups_for(const Experiment& e, const DataPair& pair, const PlannedAdapter& adapter) {
  const std::string prefix = "sweep/" + name_component(pair.model) + "/" + name_component(pair.query) + "/" + adapter.name + "/";
  const auto dists = e.dists.values();
  const int decimals = e.dists.decimals();
  std::vector<Group> groups;
  for (SearchKind kind : adapter.kinds) {
    const Strategy strategy = adapter.info.strategy(kind);
    if (kind == SearchKind::knn) {
      for (int k : e.ks) {
        groups.push_back({kind, strategy, k, {{prefix + "knn/k:" + std::to_string(k), std::nullopt, ""}}});
      }
      continue;
    }
    std::vector<std::optional<int>> ks;
    if (kind == SearchKind::radius) ks.push_back(std::nullopt);
    else ks.assign(e.ks.begin(), e.ks.end());
    const std::vector<Strategy> strategies = kind == SearchKind::ranged ? adapter.ranged_strategies
                                                                        : std::vector<Strategy>{strategy};
    for (const Strategy s : strategies) {
      for (const auto& k : ks) {
        Group group{kind, s, k, {}};
        std::string base = prefix + kind_component(kind, s, adapter);
        if (k && *k != 1) base += "k:" + std::to_string(*k) + "/";
        for (double d : dists) {
          const std::string label = format_dist(d, decimals);
          group.cells.push_back({base + "max_dist:" + label, d, label});
        }
        groups.push_back(std::move(group));
      }
    }
  }
  return groups;
}

std::vector<std::string> distinct_models(const Experiment& e) {
  std::vector<std::string> models;
  for (const auto& pair : e.pairs) {
    if (std::find(models.begin(), models.end(), pair.model) == models.end()) models.push_back(pair.model);
  }
  return models;
}

std::string build_name(const std::string& model, const std::string& adapter) {
  return "build/" + name_component(model) + "/" + adapter;
}

// Distinct distances or data set paths can print alike ("a/b" and "a_b", 1e-10 and 2e-10 m at nine
// decimals): their cells would overwrite each other, so the experiment is refused instead.
void check_unique(const std::vector<std::string>& names) {
  std::set<std::string> seen;
  for (const auto& name : names) {
    if (!seen.insert(name).second) {
      throw InputError("two cells would share the name '" + name + "': give distances or data set names that "
                       "print differently");
    }
  }
}

}  // namespace

std::vector<std::string> PlanUnit::cell_names() const {
  std::vector<std::string> names{build};
  for (const auto& [pair, groups] : work) {
    for (const auto& group : groups) {
      for (const auto& cell : group.cells) names.push_back(cell.name);
    }
  }
  return names;
}

SweepPlan::SweepPlan(const Experiment& e, const std::vector<PlannedAdapter>& adapters) {
  for (const auto& model : distinct_models(e)) {
    for (const auto& adapter : adapters) {
      PlanUnit unit{model, &adapter, build_name(model, adapter.name), {}};
      for (const auto& pair : e.pairs) {
        if (pair.model == model) unit.work.push_back({&pair, groups_for(e, pair, adapter)});
      }
      units_.push_back(std::move(unit));
    }
  }
  check_unique(cell_names());
}

std::vector<std::string> SweepPlan::cell_names(const UnitFilter& in_shard) const {
  std::vector<std::string> names;
  for (const auto& unit : units_) {
    if (in_shard && !in_shard(unit.model, unit.adapter->name)) continue;
    const auto unit_names = unit.cell_names();
    names.insert(names.end(), unit_names.begin(), unit_names.end());
  }
  return names;
}

std::vector<PlannedAdapter> plan_adapters(const Experiment& e) {
  const auto wants = [&](SearchKind kind) {
    return std::find(e.searches.begin(), e.searches.end(), to_string(kind)) != e.searches.end();
  };
  std::vector<PlannedAdapter> planned;
  for (const auto& name : e.adapters) {
    PlannedAdapter a{name, make_adapter(name)->info(), {}, {}};
    if (wants(SearchKind::ranged)) {
      a.kinds.push_back(SearchKind::ranged);
      a.ranged_strategies = a.info.strategies(SearchKind::ranged);
      if (!e.every_strategy) a.ranged_strategies.resize(1);
    }
    for (SearchKind kind : {SearchKind::knn, SearchKind::radius}) {
      const Strategy s = a.info.strategy(kind);
      if (wants(kind) && (s == Strategy::native || s == Strategy::via_box)) a.kinds.push_back(kind);
    }
    planned.push_back(std::move(a));
  }
  return planned;
}

}  // namespace nnb::sweep
