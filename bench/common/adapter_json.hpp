#pragma once
// An adapter's declared metadata as JSON: what a results file's context 'adapters' holds under the
// adapter's name, and what nns_query --list --json prints. plots/table1.py formats Table 1 from either.
#include "nnb/search_index.hpp"

#include <nlohmann/json.hpp>

#include <vector>

namespace nnb::bench {

/// The strategies' names, as to_string writes them, in the given order.
inline nlohmann::ordered_json strategy_names(const std::vector<Strategy>& strategies) {
  nlohmann::ordered_json names = nlohmann::ordered_json::array();
  for (const Strategy s : strategies) names.push_back(to_string(s));
  return names;
}

/// Library, version, structure, precision, exactness, the default strategy per search kind, every ranged
/// strategy offered (the default first), how it may use threads, the effective parameters and its notes.
inline nlohmann::ordered_json adapter_metadata(const AdapterInfo& info) {
  return {{"library", info.library}, {"version", info.version}, {"structure", info.structure},
          {"scalar", info.scalar}, {"exact", info.exact}, {"knn", to_string(info.knn)},
          {"radius", to_string(info.radius)}, {"ranged", to_string(info.ranged)},
          {"ranged_strategies", strategy_names(info.strategies(SearchKind::ranged))},
          {"concurrency", to_string(info.concurrency)}, {"builds_on_threads", info.builds_on_threads}, {"params", info.params}, {"notes", info.notes}};
}

}  // namespace nnb::bench
