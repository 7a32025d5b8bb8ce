#pragma once
// One line of the results: a construction cost or one swept cell. Plain data; results_file.cpp
// turns it into Google Benchmark-style JSON and back.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace nnb::sweep {

/// Summary of repeated wall-clock (or CPU) timings, seconds.
struct TimeStats {
  double median_s = 0.0;
  double mean_s = 0.0;
  double min_s = 0.0;
  double stddev_s = 0.0;
};

struct Record {
  enum class Type { build, sweep };
  Type type = Type::sweep;
  std::string name;     ///< unique id of the cell, e.g. sweep/hollow_sphere/hollow_cube/x/ranged/max_dist:0.20
  std::string model;
  std::string query;    ///< sweep only
  std::string adapter;
  bool exact = true;
  std::string search;   ///< ranged, knn or radius (sweep only)
  std::string strategy; ///< native, via_knn, via_radius or via_box (sweep only)
  std::optional<double> max_dist_m;  ///< absent for knn
  std::optional<int> k;              ///< absent for radius
  std::string skipped;  ///< why the cell did not run; empty when it ran
  int repetitions = 0;  ///< repetitions actually timed
  int rounds = 1;       ///< passes of the plan (--rounds) whose repetitions it holds
  int threads = 1;      ///< threads the search calls (or the build) ran on
  std::vector<double> wall_each_s;  ///< each repetition's wall time, in the order timed
  std::vector<double> cpu_each_s;   ///< each repetition's process CPU time
  TimeStats wall;       ///< of wall_each_s: per call answering all queries (sweep) or per build
  TimeStats cpu;        ///< of cpu_each_s
  std::size_t found = 0;       ///< queries with at least one neighbour
  std::size_t neighbours = 0;  ///< neighbours found over all queries
  double dist_sum_m = 0.0;     ///< sum of the distances of all neighbours found, metres
  std::optional<bool> agrees;  ///< exact adapters: same found and dist_sum as the reference
  std::string checked_against; ///< the reference adapter of that comparison
  std::string disagreement;    ///< what differed, when agrees is false
  std::size_t index_bytes = 0; ///< build only
  std::size_t build_peak_rss_bytes = 0;  ///< build only: peak RSS growth of the process while building
  std::size_t n_points = 0;    ///< points in the model
  std::size_t n_queries = 0;   ///< sweep only: points in the query cloud
  std::string skips_larger;    ///< why this adapter is skipped on models at least as large (set on the cause)
};

}  // namespace nnb::sweep
