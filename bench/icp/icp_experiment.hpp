#pragma once
// An ICP experiment file (bench/experiments/icp_*.json): which pairs, adapters, bucket sizes and ICP
// settings run_icp --experiment runs. Parsed in icp_json.cpp, the one place that includes nlohmann-json.
#include "icp.hpp"

#include <map>
#include <string>
#include <vector>

namespace nnb::icp {

/// ICP settings of an experiment (per pair if given), everything but the initial pose.
struct Settings {
  DistanceSchedule max_dist;
  int max_iterations = 50;
  double min_translation_step_m = 1e-6;
  double min_rotation_step_rad = 1e-6;
  std::size_t query_stride = 1;  ///< use every query_stride-th query point
  bool hints = true;             ///< search with the previous neighbours as hints (adapters that use them)
  bool track = false;            ///< track each query's neighbour between iterations (icp::NeighbourTrack)
  int threads = 1;               ///< threads each search may use (SearchIndex::set_threads)
};

/// Most runs of one setting an experiment may ask for: each is a cell of the plan and a record.
inline constexpr int kMaxRepetitions = 10000;

struct Experiment {
  std::string name;
  std::string description;
  std::vector<std::string> pairs;
  std::string adapter_set = "all";         ///< "all" or "with_bucket" (adapters with a bucket/leaf parameter)
  std::vector<std::string> adapters;        ///< an explicit list instead of adapter_set, if not empty
  std::vector<std::string> exclude;         ///< adapters left out (e.g. brute force on 80k x 80k)
  std::vector<int> bucket_sizes;            ///< empty = each adapter's configured value
  std::map<std::string, Params> params;     ///< extra parameters per adapter
  Settings icp;                             ///< for every pair ...
  std::map<std::string, Settings> icp_by_pair;  ///< ... unless overridden here
  int repetitions = 1;                      ///< 1 to kMaxRepetitions
  std::string out;                          ///< default output path
  /// An ICP results file with a bucket sweep (Figure 2): each adapter runs at its fastest bucket there,
  /// as the paper ran each library at its optimum. Empty: each adapter's default.
  std::string buckets_from;
  std::map<std::string, int> best_buckets;  ///< read from buckets_from, by adapter
};

/// Reads an experiment file; InputError (one line, naming the file) for a missing or malformed one.
Experiment load_experiment(const std::string& path);
/// Each adapter's bucket size with the lowest median ICP time (search and estimation) over the runs of an
/// ICP results file that neither failed nor were skipped; ties go to the smaller size. InputError (one line)
/// when the file cannot be read, is not an ICP results file or holds no such run.
std::map<std::string, int> best_buckets(const std::string& path);
/// The settings for that pair.
const Settings& settings_for(const Experiment& experiment, const std::string& pair);
/// ICP's options from an experiment's settings, starting at that pose (threads and query stride are the
/// caller's: they concern the index and the query cloud).
Options options_of(const Settings& settings, const Eigen::Matrix4d& initial);

}  // namespace nnb::icp
