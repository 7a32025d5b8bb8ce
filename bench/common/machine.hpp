#pragma once
// Facts about this machine and this build, for the results' context block.
#include <string>
#include <vector>

namespace nnb::bench {

struct CacheInfo {
  std::string type;  ///< "Data", "Instruction" or "Unified"
  int level = 0;
  long size_bytes = 0;
  int num_sharing = 0;  ///< CPUs sharing this cache
};

struct MachineInfo {
  std::string date;       ///< local time, ISO 8601 with offset
  std::string host_name;
  int num_cpus = 0;
  double mhz_per_cpu = 0.0;
  bool cpu_scaling_enabled = false;
  std::vector<CacheInfo> caches;  ///< of cpu0 from /sys, else /proc/cpuinfo's one (level 0), else none
  std::vector<double> load_avg;  ///< 1, 5 and 15 min load average when the run started
};

struct BuildInfo {
  std::string compiler;    ///< id and version
  std::string flags;       ///< CMAKE_CXX_FLAGS and those of the build type
  std::string build_type;  ///< CMAKE_BUILD_TYPE
  bool ndebug = false;     ///< assertions compiled out
  bool sanitizers = false;
  std::string git_commit;  ///< the commit built from ("+dirty" when the tree differed from it), "" when unknown
  std::string source_dir;
  /// True when timings from this binary may be published: NDEBUG and no sanitizers.
  bool release() const { return ndebug && !sanitizers; }
};

/// What a results file says about the run itself: how it was started, how long it has run, the load now.
struct RunInfo {
  std::string command_line;     ///< argv, each word quoted for a POSIX shell
  double wall_seconds = 0.0;    ///< since mark_run_start()
  std::vector<double> load_avg_now;
};

/// Marks the start of the run (the date of its results) and keeps its command line; call first in main.
void mark_run_start(int argc, char** argv);
/// The run so far.
RunInfo read_run_info();
/// Reads the machine's facts now (missing files leave fields empty); the date and load are the run's start.
MachineInfo read_machine_info();
/// The facts baked into this binary at configure time, plus the git commit read at run time.
BuildInfo read_build_info();

}  // namespace nnb::bench
