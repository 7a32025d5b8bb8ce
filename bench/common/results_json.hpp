#pragma once
// The results file every program writes (Google Benchmark's JSON: a context, then benchmarks[]): the
// fields each record starts with, the time unit, the file's text and reading it back for --resume.
// One module for run_sweep and run_icp; the records' own fields are theirs.
#include "nnb/cloud.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <istream>
#include <map>
#include <string>
#include <vector>

namespace nnb::bench::results {

using nlohmann::json;
using nlohmann::ordered_json;

/// Microseconds: compare.py prints times as whole units, and a call takes from microseconds to seconds.
inline constexpr const char* time_unit = "us";
inline constexpr double per_second = 1e6;

/// Google Benchmark's fields every record starts with: run_name groups a benchmark's repetitions and
/// aggregates, run_type is "iteration" or "aggregate".
inline ordered_json base_record(const std::string& name, const std::string& run_name, const char* run_type,
                                int repetitions, int threads) {
  ordered_json j;
  j["name"] = name;
  j["run_name"] = run_name;
  j["run_type"] = run_type;
  j["repetitions"] = repetitions;
  j["threads"] = threads;  // the threads the timed calls ran on
  return j;
}

/// JSON has no infinity: a non-finite value is written as the string "inf", "-inf" or "nan".
inline ordered_json number_or_marker(double value) {
  if (std::isfinite(value)) return value;
  return std::isnan(value) ? "nan" : value > 0 ? "inf" : "-inf";
}

/// real_time and cpu_time in time_unit, from seconds.
inline void put_times(ordered_json& j, double wall_s, double cpu_s) {
  j["real_time"] = number_or_marker(per_second * wall_s);
  j["cpu_time"] = number_or_marker(per_second * cpu_s);
  j["time_unit"] = time_unit;
}

/// Seconds from a time in one of Google Benchmark's time units (files of other versions used ms and s).
/// Divided by the unit's count per second, not multiplied by its length: v / 1e6 is the double put_times
/// turns back into v (tests/test_results_times.cpp), while v * 1e-6 is often an ulp off, so a record a
/// child hands its parent, or --resume rewrites, would not be written back as it was read.
inline double seconds_from(double value, const json& unit) {
  static const std::map<std::string, double> per_second_of{{"ns", 1e9}, {"us", 1e6}, {"ms", 1e3}, {"s", 1.0}};
  const auto it = per_second_of.find(unit.get<std::string>());
  if (it == per_second_of.end()) throw json::other_error::create(501, "unknown time_unit " + unit.dump(), nullptr);
  return value / it->second;
}

/// The file's text: the context indented, then the records (already serialised) a line each.
inline std::string file_text(const ordered_json& context, const std::vector<std::string>& records) {
  std::string text = "{\n\"context\": " + context.dump(2) + ",\n\"benchmarks\": [";
  for (std::size_t i = 0; i < records.size(); ++i) (text += i ? ",\n" : "\n") += records[i];
  return text + "\n]\n}\n";
}

/// A results file read back for --resume: refused (InputError, one line naming path) unless it is a JSON
/// object with context.config and a benchmarks list. Deeper than 64 levels is refused while reading:
/// dump() and == recurse once per level, and dump(2) indents by the depth, so 40 KB of brackets would be
/// kept as nearly a gigabyte.
template <class Json = json>
Json read_document(std::istream& in, const std::string& path, const std::string& made_by) {
  constexpr int max_nesting = 64;
  const auto refuse_deep = [&path](int depth, typename Json::parse_event_t, Json&) {
    if (depth > max_nesting) {
      throw InputError("--resume: " + path + " nests deeper than " + std::to_string(max_nesting) +
                       " levels: not a results file");
    }
    return true;
  };
  Json doc;
  try {
    doc = Json::parse(in, refuse_deep);
  } catch (const typename Json::exception& e) {
    throw InputError("--resume: " + path + " is not a results file (" + e.what() + ")");
  }
  if (!doc.is_object() || !doc.contains("context") || !doc["context"].is_object() ||
      !doc["context"].contains("config") || !doc.contains("benchmarks") || !doc["benchmarks"].is_array() ||
      (doc["context"].contains("resumed") && !doc["context"]["resumed"].is_array())) {
    throw InputError("--resume: " + path + " has no context.config or benchmarks: not made by " + made_by);
  }
  return doc;
}

/// Refuses (InputError) to resume a file whose configuration differs from this run's; compared as plain
/// JSON, so that key order does not matter.
template <class Json>
void check_same_config(const Json& doc, const std::string& wanted_config, const std::string& path,
                       const std::string& what_defines_it) {
  if (json::parse(doc["context"]["config"].dump()) != json::parse(wanted_config)) {
    throw InputError("--resume: " + path + " was made with another configuration (" + what_defines_it +
                     "); refusing to mix results. Use another --out or remove the file.");
  }
}

}  // namespace nnb::bench::results
