#pragma once
// What a sweep runs: read from a JSON file in bench/experiments/, then overridden by command-line flags.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace nnb::sweep {

/// One model/query combination. For a real pair both are the pair's name (the catalog picks the scans).
struct DataPair {
  std::string model;
  std::string query;
};

/// The swept maximal distances in metres: start + i * step for i = 0, 1, ... while <= stop.
/// More distances than this in one sweep is a mistyped step, refused before any list is built.
constexpr double kMaxDistances = 100000;
/// More passes than this over a plan is a typing error, not an experiment.
constexpr int kMaxRounds = 1000;
/// Most timed calls a cell (and builds a unit) may ask for: each is a record of the results file.
constexpr int kMaxRepetitions = 10000;

struct DistRange {
  double start_m = 0.0;
  double stop_m = 1.0;
  double step_m = 0.02;

  /// How many distances the range holds (a double: a mistyped step may make it astronomically many).
  double count() const;
  /// Every swept distance in metres, computed as start + i * step (no accumulated rounding); empty when
  /// the range is invalid or holds more than kMaxDistances.
  std::vector<double> values() const;
  /// Decimals needed to print start and step exactly (at least 2), for cell names.
  int decimals() const;
};

struct Experiment {
  std::string name;         ///< e.g. "quick"
  std::string description;
  std::string file;         ///< where it was read from
  std::vector<DataPair> pairs;
  std::vector<std::string> adapters;  ///< in registry order; from "all" when the file says so
  std::vector<std::string> searches{"ranged", "knn", "radius"};  ///< kinds considered (see runner.hpp)
  bool every_strategy = false;  ///< ranged search with every strategy an adapter offers, not only its default
  std::vector<int> ks{1};
  DistRange dists;
  int repetitions = 3;  ///< timed calls per cell at most; each is its own record
  int build_repetitions = 3;
  /// Passes over each model's units, one model after another: each pass after the first times every cell
  /// that ran (and each build) again, so that a cell's repetitions lie minutes apart rather than back to back.
  int rounds = 1;
  double budget_s = 2.0;                      ///< per cell, per repetition
  double min_time_s = 0.0;  ///< repeat a cell until its calls took this long in total (0: every repetition)
  int threads = 1;          ///< threads a search call may use (SearchIndex::set_threads); builds use one
  /// Per cell: more neighbours than this (found, or held by via_radius before it keeps k) stops larger distances.
  std::size_t neighbour_budget = 20'000'000;
  std::size_t synthetic_points = 60000;
  std::uint64_t seed = 1;
  double memory_limit_gib = 8.0;    ///< per build; see size_gate.hpp
  bool skip_larger_models = false;  ///< the time budget also skips the adapter on models at least as large
  double cell_timeout_s = 1800.0;   ///< a library that finishes no cell (or build) for this long is killed
};

/// Reads an experiment file; "adapters": "all" expands to all_adapters. Throws InputError with one line.
Experiment load_experiment(const std::string& path, const std::vector<std::string>& all_adapters);
/// Parses "start:stop:step" in metres; throws InputError for a malformed text.
DistRange parse_dists(const std::string& text);
/// Parses "a,b:c": a name alone is the pair (a, a), "model:query" a combination.
std::vector<DataPair> parse_datasets(const std::string& text);
/// Parses "default" (each adapter's default ranged strategy) or "all" (every one it offers): true for "all".
bool parse_strategies(const std::string& text);
/// Splits a comma-separated list, dropping empty items.
std::vector<std::string> split_list(const std::string& text);
/// Throws InputError for anything a run cannot do (unknown adapter, step <= 0, negative distance...).
void validate(const Experiment& experiment, const std::vector<std::string>& all_adapters);

}  // namespace nnb::sweep
