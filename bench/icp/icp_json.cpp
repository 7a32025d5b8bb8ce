#include "icp_experiment.hpp"
#include "icp_plan.hpp"
#include "icp_record.hpp"
#include "json_whole.hpp"
#include "machine_json.hpp"
#include "results_json.hpp"

#include <Eigen/LU>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace nnb::icp {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;
namespace results = bench::results;

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
  ordered_json j = results::base_record(record_name(rec), record_name(rec), "iteration", 1, rec.threads);
  j["repetition_index"] = rec.repetition;
  results::put_times(j, rec.icp_seconds, rec.icp_cpu_seconds);
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
  j["search_hints"] = rec.options.use_hints;
  j["track_neighbours"] = rec.options.track_neighbours;
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

std::string record_name(const std::string& pair, const std::string& adapter, std::optional<int> bucket_size) {
  const std::string bucket = bucket_size ? std::to_string(*bucket_size) : std::string("default");
  return "icp/" + pair + "/" + adapter + "/bucket:" + bucket;
}

std::string record_name(const Record& record) { return record_name(record.pair, record.adapter, record.bucket_size); }

std::optional<double> reference_translation_error_m(const Record& record) {
  if (!record.reference) return std::nullopt;
  return (record.result.pose.topRightCorner<3, 1>() - record.reference->topRightCorner<3, 1>()).norm();
}

std::optional<double> reference_rotation_error_deg(const Record& record) {
  if (!record.reference) return std::nullopt;
  return rotation_angle_rad(record.reference->inverse() * record.result.pose) * 180.0 / 3.14159265358979323846;
}

std::string record_text(const Record& record) { return record_json(record).dump(); }  // a record a line

std::string results_json(const std::vector<std::string>& record_texts, const std::string& build_type,
                         const RunContext& run, const std::string& earlier_context) {
  ordered_json context = machine_context(build_type);
  if (earlier_context.empty()) {
    context["experiment"] = run.experiment;  // the field name run_sweep's files use
    context["data_dir"] = run.data_dir;
    if (!run.config.empty()) context["config"] = ordered_json::parse(run.config);
    if (!run.shard.empty()) context["shard"] = ordered_json::parse(run.shard);
    if (!run.config.empty()) context["resumed"] = ordered_json::array();
  } else {  // the first run's date and machine stay; this run is noted as a resumption
    const std::string date = context["date"];
    context = ordered_json::parse(earlier_context);
    context["resumed"].push_back(date);
    bench::put_run(context, bench::read_run_info());
  }
  return results::file_text(context, record_texts);
}

std::string results_json(const std::vector<Record>& records, const std::string& build_type, const RunContext& run) {
  std::vector<std::string> texts;
  for (const auto& rec : records) texts.push_back(record_text(rec));
  return results_json(texts, build_type, run);
}

Resumed read_resumable(const std::string& path, const RunContext& run) {
  std::ifstream in(path);
  const auto doc = results::read_document<ordered_json>(in, path, "run_icp --experiment");
  results::check_same_config(doc, run.config, path, "experiment, settings, adapters, build or shard");
  Resumed resumed;
  resumed.context = doc["context"].dump();
  std::set<std::string> seen;
  try {
    for (const auto& item : doc["benchmarks"]) {
      const int repetition = bench::whole_number<int>(item.at("repetition_index"), "repetition_index");
      const std::string cell = cell_name(item.at("name").get<std::string>(), repetition);
      if (!seen.insert(cell).second) continue;
      resumed.cells.push_back(cell);
      resumed.records.push_back(item.dump());
    }
  } catch (const ordered_json::exception& e) {
    throw InputError("--resume: " + path + ": a record is malformed (" + e.what() + ")");
  } catch (const InputError& e) {
    throw InputError("--resume: " + path + ": a record is malformed (" + e.what() + ")");
  }
  return resumed;
}

// ---- plans and configuration ----

std::string cell_name(const std::string& record_name, int repetition) {
  return record_name + "#" + std::to_string(repetition);
}

namespace {

ordered_json units_json(const Plan& plan) {
  ordered_json units = ordered_json::array();
  for (const auto& u : plan.units) {
    units.push_back({{"pair", u.pair}, {"adapter", u.adapter},
                     {"bucket_size", u.bucket_size ? ordered_json(*u.bucket_size) : ordered_json(nullptr)},
                     {"cells", u.cells.size()}, {"cost", u.cost}, {"shard", u.shard}});
  }
  return units;
}

ordered_json settings_json(const Settings& s) {
  return {{"max_dist_m", s.max_dist.start_m}, {"max_dist_factor", s.max_dist.factor},
          {"max_dist_floor_m", s.max_dist.floor_m}, {"iterations", s.max_iterations},
          {"min_translation_step_m", s.min_translation_step_m}, {"min_rotation_step_rad", s.min_rotation_step_rad},
          {"query_stride", s.query_stride}, {"hints", s.hints}, {"track", s.track}, {"threads", s.threads}};
}

}  // namespace

std::string plan_json(const Plan& plan, const Experiment& e, const ShardSpec& shard,
                      const std::vector<std::string>& refused) {
  ordered_json j{{"experiment", e.name}, {"shards", plan.count}, {"total_cells", plan.total_cells},
                 {"total_units", plan.units.size()}, {"cost_model", kCostModel}, {"units", units_json(plan)},
                 {"shard_cost", plan.shard_cost}, {"shard_cells", plan.shard_cells}, {"refused", refused}};
  if (shard.given) {
    j["shard"] = shard.index;
    j["cells"] = plan.cells_of(shard.index);
  }
  return j.dump(1);
}

std::string shard_context_json(const Plan& plan, const ShardSpec& shard) {
  if (!shard.given) return "";
  // "program" tells plots/merge_results.py that units are (pair, adapter, bucket_size) and cells name#repetition.
  ordered_json j{{"program", "run_icp"}, {"index", shard.index}, {"count", shard.count},
                 {"plan_cells", plan.total_cells}, {"plan_units", plan.units.size()},
                 {"cells", plan.cells_of(shard.index)}, {"units", units_json(plan)}};
  return j.dump();
}

std::string config_json(const Experiment& e, const std::vector<AdapterVersion>& adapters, std::size_t synthetic_points,
                        std::uint64_t seed, const std::string& build_type, const std::string& shard_config) {
  ordered_json c;
  c["experiment"] = e.name;
  c["pairs"] = ordered_json::array();
  for (const auto& pair : e.pairs) {
    c["pairs"].push_back({{"pair", pair}, {"icp", settings_json(settings_for(e, pair))}});
  }
  c["adapters"] = ordered_json::array();
  for (const auto& a : adapters) c["adapters"].push_back({{"name", a.name}, {"version", a.version}});
  c["bucket_sizes"] = e.bucket_sizes;
  if (!e.buckets_from.empty()) {
    c["buckets_from"] = e.buckets_from;
    c["best_buckets"] = e.best_buckets;
  }
  c["params"] = e.params;
  c["repetitions"] = e.repetitions;
  c["synthetic_points"] = synthetic_points;
  c["seed"] = seed;
  c["build_type"] = build_type;
  if (!shard_config.empty()) c["shard"] = ordered_json::parse(shard_config);
  return c.dump();
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
    else if (key == "hints") s.hints = value.get<bool>();
    else if (key == "track") s.track = value.get<bool>();
    else if (key == "threads") s.threads = bench::whole_number<int>(value, "threads");
    else throw InputError("unknown ICP setting '" + key + "'");
  }
  if (s.query_stride < 1) throw InputError("query_stride must be at least 1");
  if (s.threads < 1 || s.threads > SearchIndex::kMaxThreads) {
    throw InputError("threads must be from 1 to " + std::to_string(SearchIndex::kMaxThreads));
  }
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
    if (!j.is_object()) throw InputError("an experiment is a JSON object");
    static const std::set<std::string> known{"name", "description", "pairs", "adapters", "exclude", "bucket_sizes",
                                             "params", "icp", "icp_by_pair", "repetitions", "out", "buckets_from"};
    for (const auto& item : j.items()) {  // a misspelt field would otherwise leave its default in force
      if (!known.count(item.key())) throw InputError("unknown field '" + item.key() + "'");
    }
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
      for (const auto& [pair, settings] : it->items()) {
        if (std::find(e.pairs.begin(), e.pairs.end(), pair) == e.pairs.end()) {
          throw InputError("icp_by_pair names '" + pair + "', which is not one of the pairs");
        }
        e.icp_by_pair[pair] = parse_settings(settings, e.icp);
      }
    }
    e.repetitions = j.contains("repetitions") ? bench::whole_number<int>(j["repetitions"], "repetitions") : 1;
    if (e.repetitions < 1 || e.repetitions > kMaxRepetitions) {
      throw InputError("repetitions must be from 1 to " + std::to_string(kMaxRepetitions));
    }
    e.out = j.value("out", "results/" + e.name + ".json");
    if (const auto it = j.find("buckets_from"); it != j.end() && !it->is_null()) e.buckets_from = it->get<std::string>();
  } catch (const json::exception& err) {
    throw InputError(path + ": " + err.what());
  } catch (const InputError& err) {
    throw InputError(path + ": " + err.what());
  }
  return e;
}

namespace {

double median_of(std::vector<double> xs) {
  std::sort(xs.begin(), xs.end());
  const std::size_t n = xs.size();
  return n % 2 ? xs[n / 2] : 0.5 * (xs[n / 2 - 1] + xs[n / 2]);
}

// A run that counts towards its bucket: timed, neither failed nor skipped.
bool counts(const json& rec) {
  return rec.is_object() && rec.contains("adapter") && rec.contains("bucket_size") && rec.contains("icp_seconds") &&
         rec["bucket_size"].is_number_integer() && rec["icp_seconds"].is_number() &&
         rec.value("failure", std::string()).empty() && !rec.contains("skipped") && !rec.contains("error_occurred");
}

}  // namespace

std::map<std::string, int> best_buckets(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("buckets_from: cannot read " + path + " (run run_icp --experiment icp_bucket first)");
  std::map<std::string, std::map<int, std::vector<double>>> seconds;  // adapter -> bucket -> ICP times
  try {
    const json doc = json::parse(in);
    for (const auto& rec : doc.at("benchmarks")) {
      if (!counts(rec)) continue;
      seconds[rec["adapter"].get<std::string>()][rec["bucket_size"].get<int>()].push_back(rec["icp_seconds"].get<double>());
    }
  } catch (const json::exception& err) {
    throw InputError("buckets_from: " + path + " is not an ICP results file (" + err.what() + ")");
  }
  std::map<std::string, int> best;
  for (const auto& [adapter, by_bucket] : seconds) {
    double fastest = 0.0;
    for (const auto& [bucket, times] : by_bucket) {  // ascending sizes: a tie keeps the smaller
      const double t = median_of(times);
      if (!best.count(adapter) || t < fastest) best[adapter] = bucket, fastest = t;
    }
  }
  if (best.empty()) throw InputError("buckets_from: " + path + " holds no timed ICP run with a bucket size");
  return best;
}

const Settings& settings_for(const Experiment& experiment, const std::string& pair) {
  const auto it = experiment.icp_by_pair.find(pair);
  return it == experiment.icp_by_pair.end() ? experiment.icp : it->second;
}

Options options_of(const Settings& s, const Eigen::Matrix4d& initial) {
  Options o;
  o.initial_pose = initial;
  o.max_dist = s.max_dist;
  o.max_iterations = s.max_iterations;
  o.min_translation_step_m = s.min_translation_step_m;
  o.min_rotation_step_rad = s.min_rotation_step_rad;
  o.use_hints = s.hints;
  o.track_neighbours = s.track;
  return o;
}

}  // namespace nnb::icp
