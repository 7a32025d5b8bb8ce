#pragma once
// One ICP run as a results record, and the results file around many of them: Google Benchmark's JSON
// schema (context + benchmarks[]), records named icp/<pair>/<adapter>/bucket:<n>. nlohmann-json stays
// inside icp_json.cpp.
#include "icp.hpp"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace nnb::icp {

struct Record {
  std::string pair;                   ///< real pair name, or model+query specs
  std::string adapter;
  std::string bucket_param;           ///< the adapter's bucket/leaf parameter name; empty if it has none
  std::optional<int> bucket_size;     ///< its effective value
  Params params;                      ///< effective adapter parameters
  std::size_t model_points = 0;
  std::size_t query_points = 0;       ///< after subsampling
  std::size_t query_stride = 1;       ///< every query_stride-th query point was used
  Options options;
  Result result;
  double icp_seconds = 0.0;           ///< wall time of search + estimation (construction excluded)
  double icp_cpu_seconds = 0.0;       ///< process CPU time of the same
  int repetition = 0;
  std::optional<Eigen::Matrix4d> reference;  ///< ground truth of the pair, if any
};

/// The record's name: icp/<pair>/<adapter>/bucket:<n> ("bucket:default" without a bucket parameter).
std::string record_name(const Record& record);
/// Translation error against the reference in metres (nothing without a reference).
std::optional<double> reference_translation_error_m(const Record& record);
/// Rotation error against the reference in degrees (nothing without a reference).
std::optional<double> reference_rotation_error_deg(const Record& record);

/// What the context says of the run beyond the machine and build: the experiment ("" for a single run)
/// and the real scan folder used.
struct RunContext {
  std::string experiment;
  std::string data_dir;
};

/// The whole results file as JSON text.
std::string results_json(const std::vector<Record>& records, const std::string& build_type, const RunContext& run);

}  // namespace nnb::icp
