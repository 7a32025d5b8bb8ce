#include "icp_experiment.hpp"
#include "icp_record.hpp"
#include "json_whole.hpp"
#include "machine_json.hpp"

#include <Eigen/LU>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace nnb::icp {
namespace {

using nlohmann::ordered_json;

// Google Benchmark's context fields and the build's, as run_sweep writes them; nnb_build_type is the
// build type as the programs report it (with "+sanitize" for sanitizer builds).
ordered_json machine_context(const std::string& build_type) {
  ordered_json c;
  char exe[4096] = {};
  const std::string executable = readlink("/proc/self/exe", exe, sizeof exe - 1) > 0 ? exe : "run_icp";
  bench::put_machine_and_build(c, bench::read_machine_info(), bench::read_build_info(), executable);
  c["nnb_build_type"] = build_type;
  return c;
}

ordered_json matrix_rows(const Eigen::Matrix4d& m) {
  ordered_json rows = ordered_json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

ordered_json record_json(const Record& rec) {
  const Result& res = rec.result;
  ordered_json j;
  j["name"] = record_name(rec);
  j["run_name"] = record_name(rec);
  j["run_type"] = "iteration";
  j["repetitions"] = 1;
  j["repetition_index"] = rec.repetition;
  j["threads"] = 1;
  j["real_time"] = rec.icp_seconds;
  j["cpu_time"] = rec.icp_cpu_seconds;
  j["time_unit"] = "s";
  j["pair"] = rec.pair;
  j["adapter"] = rec.adapter;
  j["bucket_param"] = rec.bucket_param;
  j["bucket_size"] = rec.bucket_size ? ordered_json(*rec.bucket_size) : ordered_json(nullptr);
  j["params"] = rec.params;
  j["icp_seconds"] = rec.icp_seconds;
  j["build_seconds"] = res.build_seconds;
  j["nns_seconds"] = res.nns_seconds;
  j["estimate_seconds"] = res.estimate_seconds;
  j["iterations"] = res.iterations;
  j["converged"] = res.converged;
  j["failure"] = res.failure;
  j["rms_m"] = res.final_rms_m();
  j["correspondences"] = res.final_correspondences();
  j["model_points"] = rec.model_points;
  j["query_points"] = rec.query_points;
  j["query_stride"] = rec.query_stride;
  j["max_dist_start_m"] = rec.options.max_dist.start_m;
  j["max_dist_factor"] = rec.options.max_dist.factor;
  j["max_dist_floor_m"] = rec.options.max_dist.floor_m;
  j["max_iterations"] = rec.options.max_iterations;
  j["min_translation_step_m"] = rec.options.min_translation_step_m;
  j["min_rotation_step_rad"] = rec.options.min_rotation_step_rad;
  j["initial_pose"] = matrix_rows(rec.options.initial_pose);
  j["final_pose"] = matrix_rows(res.pose);
  if (rec.reference) {
    j["reference_pose"] = matrix_rows(*rec.reference);
    j["ref_translation_error_m"] = *reference_translation_error_m(rec);
    j["ref_rotation_error_deg"] = *reference_rotation_error_deg(rec);
  }
  ordered_json per = ordered_json::array();
  for (const auto& it : res.per_iteration) {
    per.push_back({{"max_dist_m", it.max_dist_m},
                   {"correspondences", it.correspondences},
                   {"rms_m", it.rms_m},
                   {"rms_after_m", it.rms_after_m},
                   {"translation_step_m", it.translation_step_m},
                   {"rotation_step_rad", it.rotation_step_rad}});
  }
  j["per_iteration"] = per;
  return j;
}

}  // namespace

std::string record_name(const Record& record) {
  const std::string bucket = record.bucket_size ? std::to_string(*record.bucket_size) : std::string("default");
  return "icp/" + record.pair + "/" + record.adapter + "/bucket:" + bucket;
}

std::optional<double> reference_translation_error_m(const Record& record) {
  if (!record.reference) return std::nullopt;
  return (record.result.pose.topRightCorner<3, 1>() - record.reference->topRightCorner<3, 1>()).norm();
}

std::optional<double> reference_rotation_error_deg(const Record& record) {
  if (!record.reference) return std::nullopt;
  return rotation_angle_rad(record.reference->inverse() * record.result.pose) * 180.0 / 3.14159265358979323846;
}

std::string results_json(const std::vector<Record>& records, const std::string& build_type, const RunContext& run) {
  ordered_json doc;
  doc["context"] = machine_context(build_type);
  doc["context"]["experiment"] = run.experiment;  // the field name run_sweep's files use
  doc["context"]["data_dir"] = run.data_dir;
  doc["benchmarks"] = ordered_json::array();
  for (const auto& rec : records) doc["benchmarks"].push_back(record_json(rec));
  return doc.dump(2) + "\n";
}

}  // namespace nnb::icp

// ---- experiment files ----

namespace nnb::icp {
namespace {

using nlohmann::json;

Settings parse_settings(const json& j, Settings s) {
  for (const auto& [key, value] : j.items()) {
    if (key == "max_dist_m") s.max_dist.start_m = value.get<double>();
    else if (key == "max_dist_factor") s.max_dist.factor = value.get<double>();
    else if (key == "max_dist_floor_m") s.max_dist.floor_m = value.get<double>();
    else if (key == "iterations") s.max_iterations = bench::whole_number<int>(value, "iterations");
    else if (key == "min_translation_step_m") s.min_translation_step_m = value.get<double>();
    else if (key == "min_rotation_step_rad") s.min_rotation_step_rad = value.get<double>();
    else if (key == "query_stride") s.query_stride = bench::whole_number<std::size_t>(value, "query_stride");
    else throw InputError("unknown ICP setting '" + key + "'");
  }
  if (s.query_stride < 1) throw InputError("query_stride must be at least 1");
  Options checked;  // refused here, before any run, not skipped run by run
  checked.max_dist = s.max_dist;
  checked.max_iterations = s.max_iterations;
  checked.min_translation_step_m = s.min_translation_step_m;
  checked.min_rotation_step_rad = s.min_rotation_step_rad;
  validate(checked);
  return s;
}

std::vector<int> parse_buckets(const json& j) {
  std::vector<int> sizes;
  if (j.is_string()) {  // "first:last" or "first:last:step"
    const std::string text = j.get<std::string>();
    int first = 0, last = 0, step = 1;
    char c1 = 0, c2 = 0;
    std::istringstream in(text);
    in >> first >> c1 >> last;
    if (!(in >> c2 >> step)) step = 1;
    if (c1 != ':' || first < 1 || last < first || step < 1) throw InputError("bad bucket range '" + text + "'");
    for (int b = first; b <= last; b += step) sizes.push_back(b);
  } else {
    for (const auto& size : j) sizes.push_back(bench::whole_number<int>(size, "a bucket size"));
  }
  return sizes;
}

}  // namespace

Experiment load_experiment(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot read experiment file " + path);
  Experiment e;
  try {
    const json j = json::parse(in);
    e.name = j.at("name").get<std::string>();
    e.description = j.value("description", "");
    e.pairs = j.at("pairs").get<std::vector<std::string>>();
    if (const auto it = j.find("adapters"); it != j.end()) {
      if (it->is_string()) e.adapter_set = it->get<std::string>();
      else e.adapters = it->get<std::vector<std::string>>();
    }
    if (e.adapter_set != "all" && e.adapter_set != "with_bucket") {
      throw InputError("adapters must be \"all\", \"with_bucket\" or a list of names");
    }
    e.exclude = j.value("exclude", std::vector<std::string>{});
    if (const auto it = j.find("bucket_sizes"); it != j.end() && !it->is_null()) e.bucket_sizes = parse_buckets(*it);
    if (const auto it = j.find("params"); it != j.end()) {
      for (const auto& [adapter, params] : it->items()) e.params[adapter] = params.get<Params>();
    }
    if (const auto it = j.find("icp"); it != j.end()) e.icp = parse_settings(*it, e.icp);
    if (const auto it = j.find("icp_by_pair"); it != j.end()) {
      for (const auto& [pair, settings] : it->items()) e.icp_by_pair[pair] = parse_settings(settings, e.icp);
    }
    e.repetitions = j.contains("repetitions") ? bench::whole_number<int>(j["repetitions"], "repetitions") : 1;
    if (e.repetitions < 1) throw InputError("repetitions must be at least 1");
    e.out = j.value("out", "results/" + e.name + ".json");
  } catch (const json::exception& err) {
    throw InputError(path + ": " + err.what());
  } catch (const InputError& err) {
    throw InputError(path + ": " + err.what());
  }
  return e;
}

const Settings& settings_for(const Experiment& experiment, const std::string& pair) {
  const auto it = experiment.icp_by_pair.find(pair);
  return it == experiment.icp_by_pair.end() ? experiment.icp : it->second;
}

}  // namespace nnb::icp
