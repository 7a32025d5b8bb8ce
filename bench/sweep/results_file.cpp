// Records to and from Google Benchmark-style JSON; the atomic writer. One of the two nlohmann TUs.
#include "results_file.hpp"

#include "adapter_json.hpp"
#include "files.hpp"
#include "isolation.hpp"
#include "json_whole.hpp"
#include "machine_json.hpp"
#include "results_json.hpp"
#include "nnb/cloud.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <csignal>
#include <limits>
#include <map>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace nnb::sweep {

using nlohmann::json;
using nlohmann::ordered_json;
namespace results = bench::results;
using results::number_or_marker;

struct ResultsFile::Json {
  ordered_json context;
};

namespace {

ordered_json config_of(const RunDescription& run) {
  const Experiment& e = *run.experiment;
  ordered_json c;
  c["experiment"] = e.name;
  c["pairs"] = ordered_json::array();
  for (const auto& p : e.pairs) c["pairs"].push_back({{"model", p.model}, {"query", p.query}});
  c["adapters"] = ordered_json::array();
  for (const auto& a : *run.adapters) {
    ordered_json kinds = ordered_json::array();
    for (auto kind : a.kinds) kinds.push_back(to_string(kind));
    c["adapters"].push_back({{"name", a.name}, {"version", a.info.version}, {"params", a.info.params},
                             {"searches", kinds}, {"ranged_strategies", bench::strategy_names(a.ranged_strategies)}});
  }
  c["k"] = e.ks;
  c["dists"] = {{"start_m", e.dists.start_m}, {"stop_m", e.dists.stop_m}, {"step_m", e.dists.step_m}};
  c["repetitions"] = e.repetitions;
  c["build_repetitions"] = e.build_repetitions;
  if (e.rounds > 1) c["rounds"] = e.rounds;  // absent: one, so that files of one round resume as before
  c["budget_seconds"] = e.budget_s;
  c["min_time_seconds"] = e.min_time_s;
  c["threads"] = e.threads;
  c["neighbour_budget"] = e.neighbour_budget;
  c["synthetic_points"] = e.synthetic_points;
  c["seed"] = e.seed;
  c["strategies"] = e.every_strategy ? "all" : "default";
  c["memory_limit_gib"] = e.memory_limit_gib;
  c["skip_larger_models"] = e.skip_larger_models;
  c["build_type"] = run.build.build_type;
  c["release"] = run.build.release();
  if (!run.shard_config.empty()) c["shard"] = ordered_json::parse(run.shard_config);
  return c;
}

ordered_json datasets_of(const LoadedData& data) {
  ordered_json list = ordered_json::array();
  for (const auto* role : {&data.models, &data.queries}) {
    for (const auto& [spec, cloud] : *role) {
      ordered_json d{{"spec", spec}, {"role", role == &data.models ? "model" : "query"}, {"kind", cloud.kind},
                     {"source", cloud.source}, {"points", cloud.points.cols()}, {"n_read", cloud.n_read},
                     {"n_dropped", cloud.n_dropped}};
      if (cloud.kind == "synthetic") d["seed"] = cloud.seed;
      if (!cloud.sha256.empty()) d["sha256"] = cloud.sha256;
      list.push_back(d);
    }
  }
  return list;
}

ordered_json context_of(const RunDescription& run) {
  ordered_json c;
  bench::put_machine_and_build(c, run.machine, run.build, "run_sweep");
  c["experiment"] = run.experiment->name;
  c["experiment_file"] = run.experiment->file;
  c["config"] = config_of(run);
  c["adapters"] = ordered_json::object();  // by name, as plots/results_io.py reads it
  for (const auto& a : *run.adapters) {
    c["adapters"][a.info.name] = bench::adapter_metadata(a.info);
  }
  c["datasets"] = datasets_of(*run.data);
  if (!run.shard_context.empty()) c["shard"] = ordered_json::parse(run.shard_context);
  c["resumed"] = ordered_json::array();
  return c;
}

double read_number(const json& j) {
  if (j.is_number()) return j.get<double>();
  const std::string text = j.get<std::string>();
  if (text == "inf") return std::numeric_limits<double>::infinity();
  if (text == "-inf") return -std::numeric_limits<double>::infinity();
  if (text == "nan") return std::numeric_limits<double>::quiet_NaN();
  throw json::type_error::create(302, "not a number or a non-finite marker: '" + text + "'", nullptr);
}

void put_stats(ordered_json& j, const char* prefix, const TimeStats& s) {
  const std::string p = prefix;
  j[p + "median_s"] = number_or_marker(s.median_s);
  j[p + "mean_s"] = number_or_marker(s.mean_s);
  j[p + "min_s"] = number_or_marker(s.min_s);
  j[p + "stddev_s"] = number_or_marker(s.stddev_s);
}

// What names the cell, on each of its records, so that every record reads alone (compare.py, to_csv.py).
void put_identity(ordered_json& j, const Record& r) {
  j["type"] = r.type == Record::Type::build ? "build" : "sweep";
  j["model"] = r.model;
  if (r.type == Record::Type::sweep) j["query"] = r.query;
  j["adapter"] = r.adapter;
  j["exact"] = r.exact;
  if (r.type == Record::Type::build) return;
  j["search"] = r.search;
  j["strategy"] = r.strategy;
  if (r.max_dist_m) j["max_dist"] = *r.max_dist_m;
  if (r.k) j["k"] = *r.k;
}

// What the cell found and cost: carried once, by the median aggregate (or by the record of a skipped cell).
void put_cell(ordered_json& j, const Record& r) {
  if (r.skipped.empty()) {
    put_stats(j, "", r.wall);
    put_stats(j, "cpu_", r.cpu);
  }
  j["n_points"] = r.n_points;
  if (r.rounds > 1) j["rounds"] = r.rounds;
  if (!r.skips_larger.empty()) j["skips_larger_models"] = r.skips_larger;
  if (r.type == Record::Type::build) {
    if (r.skipped.empty()) j["build_seconds"] = r.wall.median_s;
    j["index_bytes"] = r.index_bytes;
    j["index_bytes_per_point"] =
        r.n_points > 0 ? static_cast<double>(r.index_bytes) / static_cast<double>(r.n_points) : 0.0;
    j["build_peak_rss_bytes"] = r.build_peak_rss_bytes;
    return;
  }
  j["n_queries"] = r.n_queries;
  if (r.skipped.empty() && r.n_queries > 0) {
    j["seconds_per_query"] = r.wall.median_s / static_cast<double>(r.n_queries);
  }
  j["found"] = r.found;
  j["neighbours"] = r.neighbours;
  j["dist_sum"] = number_or_marker(r.dist_sum_m);
  if (r.agrees) {
    j["agrees"] = *r.agrees;
    j["checked_against"] = r.checked_against;
    if (!*r.agrees) j["disagreement"] = r.disagreement;
  }
}

ordered_json base_record(const Record& r, const std::string& name, const char* run_type) {
  return results::base_record(name, r.name, run_type, r.repetitions, r.threads);
}

// Google Benchmark's aggregates of the repetitions: mean and median, and with two or more, stddev and cv
// (cv as a fraction, as Google Benchmark writes it, with aggregate_unit "percentage").
void put_aggregates(std::vector<ordered_json>& out, const Record& r) {
  struct Aggregate {
    const char* name;
    double wall_s, cpu_s;
  };
  std::vector<Aggregate> aggregates{{"mean", r.wall.mean_s, r.cpu.mean_s}, {"median", r.wall.median_s, r.cpu.median_s}};
  if (r.wall_each_s.size() >= 2) {  // stddev: the sample's (n - 1), as Google Benchmark's
    aggregates.push_back({"stddev", r.wall.stddev_s, r.cpu.stddev_s});
    aggregates.push_back({"cv", r.wall.mean_s > 0 ? r.wall.stddev_s / r.wall.mean_s : 0.0,
                          r.cpu.mean_s > 0 ? r.cpu.stddev_s / r.cpu.mean_s : 0.0});
  }
  for (const auto& a : aggregates) {
    const std::string agg = a.name;
    ordered_json j = base_record(r, r.name + "_" + agg, "aggregate");
    j["aggregate_name"] = agg;
    j["aggregate_unit"] = agg == "cv" ? "percentage" : "time";
    j["iterations"] = r.repetitions;
    if (agg == "cv") {
      j["real_time"] = number_or_marker(a.wall_s);
      j["cpu_time"] = number_or_marker(a.cpu_s);
      j["time_unit"] = results::time_unit;
    } else {
      results::put_times(j, a.wall_s, a.cpu_s);
    }
    put_identity(j, r);
    if (agg == "median") put_cell(j, r);
    out.push_back(std::move(j));
  }
}

// A cell's records, as Google Benchmark writes a benchmark run with repetitions: one per timed repetition,
// then the aggregates. A skipped cell is one record marked as Google Benchmark marks an error, without
// times, so that compare.py and the aggregates leave it out.
std::vector<ordered_json> to_json(const Record& r) {
  std::vector<ordered_json> out;
  if (!r.skipped.empty() || r.wall_each_s.empty()) {
    ordered_json j = base_record(r, r.name, "iteration");
    j["repetition_index"] = 0;
    j["iterations"] = 0;
    if (!r.skipped.empty()) {
      j["error_occurred"] = true;
      j["error_message"] = r.skipped;
      j["skipped"] = r.skipped;
    }
    put_identity(j, r);
    put_cell(j, r);
    out.push_back(std::move(j));
    return out;
  }
  for (std::size_t i = 0; i < r.wall_each_s.size(); ++i) {
    ordered_json j = base_record(r, r.name, "iteration");
    j["repetition_index"] = i;
    j["iterations"] = 1;
    results::put_times(j, r.wall_each_s[i], i < r.cpu_each_s.size() ? r.cpu_each_s[i] : 0.0);
    put_identity(j, r);
    out.push_back(std::move(j));
  }
  put_aggregates(out, r);
  return out;
}

// A count or size read back as a whole number within Int's range: a file may hold 1e30, 2.5 or -1 there,
// which get<Int>() would wrap or cast with undefined behaviour.
template <class Int>
Int whole(const json& j, const char* key) {
  return bench::whole_number<Int>(j.at(key), key);
}

template <class Int>
Int whole_or(const json& j, const char* key, Int fallback) {
  return j.contains(key) ? whole<Int>(j, key) : fallback;
}

TimeStats get_stats(const json& j, const std::string& p) {
  if (!j.contains(p + "median_s")) return {};  // a skipped cell has no times
  return {read_number(j.at(p + "median_s")), read_number(j.at(p + "mean_s")), read_number(j.at(p + "min_s")),
          read_number(j.at(p + "stddev_s"))};
}

bool is_aggregate(const json& j) { return j.value("run_type", std::string()) == "aggregate"; }

// The record of a cell's group that carries the cell: the median aggregate, else the one record of a
// skipped cell (or of a file written before repetitions were records).
const json& cell_record(const std::vector<const json*>& group) {
  for (const json* j : group) {
    if (is_aggregate(*j) && j->value("aggregate_name", std::string()) == "median") return *j;
  }
  if (group.size() == 1 && !is_aggregate(*group.front())) return *group.front();
  throw json::other_error::create(501, "cell '" + group.front()->value("run_name", std::string()) +
                                           "' has repetitions but no median aggregate", nullptr);
}

// One cell back from its records (see to_json).
Record from_json(const std::vector<const json*>& group) {
  const json& j = cell_record(group);
  Record r;
  r.type = j.at("type") == "build" ? Record::Type::build : Record::Type::sweep;
  r.name = j.contains("run_name") ? j.at("run_name").get<std::string>() : j.at("name").get<std::string>();
  r.model = j.at("model").get<std::string>();
  r.adapter = j.at("adapter").get<std::string>();
  r.exact = j.at("exact").get<bool>();
  r.repetitions = whole<int>(j, "repetitions");
  r.rounds = whole_or<int>(j, "rounds", 1);
  r.threads = whole_or<int>(j, "threads", 1);
  r.wall = get_stats(j, "");
  r.cpu = get_stats(j, "cpu_");
  for (const json* rep : group) {
    if (is_aggregate(*rep) || !rep->contains("real_time") || rep->contains("median_s")) continue;
    const json& unit = rep->at("time_unit");
    r.wall_each_s.push_back(results::seconds_from(read_number(rep->at("real_time")), unit));
    r.cpu_each_s.push_back(results::seconds_from(read_number(rep->at("cpu_time")), unit));
  }
  if (j.contains("skipped")) r.skipped = j["skipped"].get<std::string>();
  r.n_points = whole_or<std::size_t>(j, "n_points", 0);  // sweep records of older files lack it
  r.skips_larger = j.value("skips_larger_models", std::string());
  if (r.type == Record::Type::build) {
    r.index_bytes = whole<std::size_t>(j, "index_bytes");
    r.n_points = whole<std::size_t>(j, "n_points");
    r.build_peak_rss_bytes = whole_or<std::size_t>(j, "build_peak_rss_bytes", 0);
    return r;
  }
  r.n_queries = whole_or<std::size_t>(j, "n_queries", 0);
  r.query = j.at("query").get<std::string>();
  r.search = j.at("search").get<std::string>();
  r.strategy = j.at("strategy").get<std::string>();
  if (j.contains("max_dist")) r.max_dist_m = j["max_dist"].get<double>();
  if (j.contains("k")) r.k = whole<int>(j, "k");
  r.found = whole<std::size_t>(j, "found");
  r.neighbours = whole<std::size_t>(j, "neighbours");
  r.dist_sum_m = read_number(j.at("dist_sum"));
  if (j.contains("agrees")) {
    r.agrees = j["agrees"].get<bool>();
    r.checked_against = j.at("checked_against").get<std::string>();
    if (j.contains("disagreement")) r.disagreement = j["disagreement"].get<std::string>();
  }
  return r;
}

std::string run_name_of(const json& j) {
  const json& name = j.contains("run_name") ? j.at("run_name") : j.at("name");
  return name.get<std::string>();
}

// The records of a list, grouped by cell (run_name) in order of first appearance.
std::vector<std::vector<const json*>> cell_groups(const json& records) {
  std::vector<std::vector<const json*>> groups;
  std::map<std::string, std::size_t> where;
  for (const auto& item : records) {
    const auto [it, fresh] = where.emplace(run_name_of(item), groups.size());
    if (fresh) groups.emplace_back();
    groups[it->second].push_back(&item);
  }
  return groups;
}

std::string serialise(const std::vector<ordered_json>& records) {
  std::string text;
  for (const auto& j : records) (text += text.empty() ? "" : ",\n") += j.dump();  // a record a line
  return text;
}

}  // namespace

std::string batch_to_json_line(const std::vector<Record>& batch) {
  ordered_json list = ordered_json::array();
  for (const auto& r : batch) {
    for (auto& j : to_json(r)) list.push_back(std::move(j));
  }
  return list.dump();
}

std::vector<Record> batch_from_json_line(const std::string& line) {
  const json list = json::parse(line);
  std::vector<Record> batch;
  for (const auto& group : cell_groups(list)) batch.push_back(from_json(group));
  return batch;
}

ResultsFile::ResultsFile(std::string path, const RunDescription& run)
    : path_(std::move(path)), json_(std::make_unique<Json>()) {
  json_->context = context_of(run);
}

ResultsFile::~ResultsFile() = default;

namespace {

json parse_document(std::istream& in, const std::string& path) {
  return results::read_document(in, path, "run_sweep");
}

std::vector<StoredRecord> read_records(const json& doc, const std::string& path, bool retry_failed) {
  std::vector<StoredRecord> stored;
  std::set<std::string> names;
  try {
    for (const auto& group : cell_groups(doc.at("benchmarks"))) {
      Record r = from_json(group);
      if (retry_failed && is_failure(r)) continue;
      // Rewritten as read (key order and fields of other versions kept), not as to_json would make it.
      std::vector<ordered_json> as_read;
      for (const json* item : group) as_read.push_back(ordered_json::parse(item->dump()));
      if (names.insert(r.name).second) stored.push_back({r, serialise(as_read)});
    }
  } catch (const json::exception& e) {
    throw InputError("--resume: " + path + ": a record is malformed (" + e.what() + ")");
  } catch (const InputError& e) {
    throw InputError("--resume: " + path + ": a record is malformed (" + e.what() + ")");
  }
  return stored;
}

}  // namespace

std::vector<StoredRecord> parse_results(const std::string& text, const std::string& path, bool retry_failed) {
  std::istringstream in(text);
  return read_records(parse_document(in, path), path, retry_failed);
}

bool ResultsFile::resume(bool retry_failed) {
  if (!std::filesystem::exists(path_)) return false;
  std::ifstream in(path_);
  json doc = parse_document(in, path_);
  results::check_same_config(doc, json_->context["config"].dump(), path_, "experiment, flags, adapters or build");
  // Keep the original context (its date and machine), noting this resumption.
  ordered_json original = ordered_json::parse(doc["context"].dump());
  original["resumed"].push_back(json_->context["date"]);
  json_->context = original;
  for (auto& [record, text] : read_records(doc, path_, retry_failed)) {
    where_.emplace(record.name, records_.size());
    records_.push_back(std::move(record));
    serialised_.push_back(std::move(text));
  }
  return true;
}

const Record* ResultsFile::find(const std::string& name) const {
  const auto it = where_.find(name);
  return it == where_.end() ? nullptr : &records_[it->second];
}

void ResultsFile::add(const std::vector<Record>& batch) {
  for (const auto& r : batch) {
    const auto [it, fresh] = where_.emplace(r.name, records_.size());
    if (fresh) {
      records_.push_back(r);
      serialised_.push_back(serialise(to_json(r)));
    } else if (r.rounds > records_[it->second].rounds) {
      records_[it->second] = r;
      serialised_[it->second] = serialise(to_json(r));
    } else {
      continue;
    }
    pending_bytes_ += serialised_[it->second].size();
  }
  if (checkpoint_due()) write();
  if (const int signal = files::interrupted()) {
    throw Interrupted(std::string("stopped by ") + strsignal(signal) + " with " + std::to_string(records_.size()) +
                      " records written to " + path_);
  }
  added_ += batch.size();
  if (abort_after_ > 0 && added_ >= abort_after_) {
    write();
    std::fprintf(stderr, "run_sweep: NNB_SWEEP_ABORT_AFTER_CELLS reached, killing myself\n");
    std::raise(SIGKILL);
  }
}

// The whole file is rewritten at a checkpoint only when what is new is at least an eighth of what was
// written, or a minute has passed (small files: always): a long run writes a bounded multiple of its final size, not its square.
// An interrupt always writes, so SIGINT and SIGTERM lose nothing.
bool ResultsFile::checkpoint_due() const {
  const auto since = std::chrono::steady_clock::now() - last_write_;
  return files::interrupted() != 0 || written_bytes_ < (64u << 10) || pending_bytes_ * 8 >= written_bytes_ ||
         since >= std::chrono::minutes(1);
}

void ResultsFile::write() {
  bench::put_run(json_->context, bench::read_run_info());
  const std::string text = results::file_text(json_->context, serialised_);
  files::write_file_atomically(path_, text);
  written_bytes_ = text.size();
  pending_bytes_ = 0;
  last_write_ = std::chrono::steady_clock::now();
}

}  // namespace nnb::sweep
