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
  int threads = 1;                    ///< threads the searches ran on
  Options options;
  Result result;
  double icp_seconds = 0.0;           ///< wall time of search + estimation (construction excluded)
  double icp_cpu_seconds = 0.0;       ///< process CPU time of the same
  int repetition = 0;
  std::optional<Eigen::Matrix4d> reference;  ///< ground truth of the pair, if any
};

/// The record's name: icp/<pair>/<adapter>/bucket:<n> ("bucket:default" without a bucket parameter).
std::string record_name(const Record& record);
std::string record_name(const std::string& pair, const std::string& adapter, std::optional<int> bucket_size);
/// Translation error against the reference in metres (nothing without a reference).
std::optional<double> reference_translation_error_m(const Record& record);
/// Rotation error against the reference in degrees (nothing without a reference).
std::optional<double> reference_rotation_error_deg(const Record& record);

/// What the context says of the run beyond the machine and build: the experiment ("" for a single run),
/// the real scan folder used, and for an experiment its configuration and shard.
struct RunContext {
  std::string experiment;
  std::string data_dir;
  std::string config;  ///< JSON text put in context as "config" (icp_plan.hpp); empty for a single run
  std::string shard;   ///< JSON text put in context as "shard"; empty when not sharded
};

/// One record as JSON text, as the results file holds it.
std::string record_text(const Record& record);
/// The whole results file as JSON text around records already made text (record_text, or kept from the
/// file a run resumes); earlier_context: that file's context (JSON text), whose date and machine the file
/// keeps with this run's date added to "resumed"; empty for a fresh run.
std::string results_json(const std::vector<std::string>& record_texts, const std::string& build_type,
                         const RunContext& run, const std::string& earlier_context = "");
/// The whole results file of these records as JSON text.
std::string results_json(const std::vector<Record>& records, const std::string& build_type, const RunContext& run);

/// What --resume keeps of an earlier results file.
struct Resumed {
  std::string context;               ///< its context, as JSON text
  std::vector<std::string> records;  ///< its records as JSON text, in its order
  std::vector<std::string> cells;    ///< their cell names (icp_plan.hpp's cell_name)
};

/// Reads the file at path for --resume; throws InputError when it is not a results file or was made with
/// another configuration than run.config (experiment, settings, adapters, build or shard).
Resumed read_resumable(const std::string& path, const RunContext& run);

}  // namespace nnb::icp
