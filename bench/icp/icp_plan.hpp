#pragma once
// The units of an ICP experiment and their shards (run_icp --shard I/N, --plan): one unit is one
// (pair, adapter, bucket size) setting with its repetitions as cells, split by run_sweep's rule
// (sweep/shard.hpp). Built in run_icp.cpp; made JSON in icp_json.cpp.
#include "../sweep/shard.hpp"
#include "icp_experiment.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nnb::icp {

using sweep::ShardSpec;

struct Unit {
  std::string spec;                ///< the pair as the experiment names it (what is loaded)
  std::string pair;                ///< as records name it
  std::string adapter;
  Params params;                   ///< the experiment's, with the bucket size set
  std::string bucket_param;        ///< empty when the adapter has none
  std::optional<int> bucket_size;  ///< effective value, as records hold it
  std::vector<std::string> cells;  ///< cell_name of each repetition
  double cost = 0.0;               ///< see kCostModel
  int shard = 0;
};

using Plan = sweep::BasicShardPlan<Unit>;

/// What Unit::cost estimates.
inline constexpr const char* kCostModel =
    "(query points x iteration limit + model points) x repetitions x adapter factor, in 1e6";

/// A cell of the plan: the record's name and its repetition ("icp/<pair>/<adapter>/bucket:<n>#<repetition>").
std::string cell_name(const std::string& record_name, int repetition);

/// The plan as JSON text (units, shards, costs; the chosen shard's cells when one is given), with the
/// settings the libraries refused (run nowhere).
std::string plan_json(const Plan& plan, const Experiment& experiment, const ShardSpec& shard,
                      const std::vector<std::string>& refused);
/// What a shard puts in context as "shard" (the spec, the plan's units and the shard's cells), as JSON text;
/// empty when not sharded.
std::string shard_context_json(const Plan& plan, const ShardSpec& shard);

/// An adapter of the experiment as its configuration names it.
struct AdapterVersion {
  std::string name;
  std::string version;
};

/// The experiment as run, as JSON text for context.config: what a resumed file and the shards of one
/// run must share (shard_config: sweep::shard_config_json, joined as "shard" when not empty).
std::string config_json(const Experiment& experiment, const std::vector<AdapterVersion>& adapters,
                        std::size_t synthetic_points, std::uint64_t seed, const std::string& build_type,
                        const std::string& shard_config);

}  // namespace nnb::icp
