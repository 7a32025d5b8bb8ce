#pragma once
// The machine and build facts as fields of a results file's context block, under Google Benchmark's
// names where it has them: one writer for run_sweep and run_icp.
#include "machine.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace nnb::bench {

/// The run's own provenance; rewritten at every checkpoint, so that the file always says how long the run
/// took and the load at its end.
inline void put_run(nlohmann::ordered_json& c, const RunInfo& run) {
  c["command_line"] = run.command_line;
  c["wall_seconds"] = run.wall_seconds;
  c["load_avg_after"] = run.load_avg_now;
}

inline void put_machine_and_build(nlohmann::ordered_json& c, const MachineInfo& m, const BuildInfo& b,
                                  const std::string& executable) {
  c["date"] = m.date;
  c["host_name"] = m.host_name;
  c["executable"] = executable;
  c["num_cpus"] = m.num_cpus;
  c["mhz_per_cpu"] = static_cast<long>(m.mhz_per_cpu + 0.5);
  c["cpu_scaling_enabled"] = m.cpu_scaling_enabled;
  c["caches"] = nlohmann::ordered_json::array();
  for (const auto& cache : m.caches) {
    c["caches"].push_back({{"type", cache.type}, {"level", cache.level}, {"size", cache.size_bytes},
                           {"num_sharing", cache.num_sharing}});
  }
  c["load_avg"] = m.load_avg;
  c["library_build_type"] = b.ndebug ? "release" : "debug";
  c["compiler"] = b.compiler;
  c["flags"] = b.flags;
  c["build_type"] = b.build_type;
  c["ndebug"] = b.ndebug;
  c["sanitizers"] = b.sanitizers;
  c["git_commit"] = b.git_commit.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(b.git_commit);
  const std::string dirty = "+dirty";
  c["git_dirty"] = b.git_commit.size() >= dirty.size() &&
                   b.git_commit.compare(b.git_commit.size() - dirty.size(), dirty.size(), dirty) == 0;
  put_run(c, read_run_info());
}

}  // namespace nnb::bench
