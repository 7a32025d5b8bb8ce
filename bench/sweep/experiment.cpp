// Experiment files (JSON) and the flag syntaxes that override them. One of the two nlohmann TUs.
#include "experiment.hpp"

#include "json_whole.hpp"
#include "nnb/cloud.hpp"
#include "nnb/search_index.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <type_traits>
#include <fstream>
#include <set>
#include <sstream>

namespace nnb::sweep {
namespace {

// A number as a message shows it: 0.05, 1e-12, 1e+300.
std::string number_text(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

using nlohmann::json;

double parse_number(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) throw InputError(what + ": '" + text + "' is not a number");
  return value;
}

template <class T>
T get(const json& object, const char* key, const std::string& file) {
  try {
    return object.at(key).get<T>();
  } catch (const json::exception&) {
    throw InputError(file + ": field '" + key + "' is missing or has the wrong type");
  }
}

template <class Int>
Int get_whole(const json& object, const char* key, const std::string& file) {
  return bench::whole_number<Int>(object.at(key), file + ": field '" + key + "'");
}

std::vector<int> get_whole_list(const json& object, const char* key, const std::string& file) {
  const json& list = object.at(key);
  if (!list.is_array()) throw InputError(file + ": field '" + std::string(key) + "' must be a list");
  std::vector<int> values;
  for (const auto& item : list) values.push_back(bench::whole_number<int>(item, file + ": an entry of '" + key + "'"));
  return values;
}

bool exactly_decimal(double value, int decimals) {
  const double scaled = value * std::pow(10.0, decimals);
  return std::abs(scaled - std::round(scaled)) < 1e-9 * std::max(1.0, std::abs(scaled));
}

}  // namespace

double DistRange::count() const {
  if (!(step_m > 0.0) || !(stop_m >= start_m)) return 0.0;
  return std::floor((stop_m - start_m) / step_m + 1e-9) + 1.0;
}

std::vector<double> DistRange::values() const {
  std::vector<double> out;
  const double n = count();
  if (!(n >= 1.0 && n <= kMaxDistances)) return out;  // validate() refuses these with a reason
  for (long i = 0; i < static_cast<long>(n); ++i) out.push_back(start_m + static_cast<double>(i) * step_m);
  return out;
}

int DistRange::decimals() const {
  int d = 2;
  while (d < 9 && !(exactly_decimal(start_m, d) && exactly_decimal(step_m, d))) ++d;
  return d;
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

DistRange parse_dists(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ':')) parts.push_back(part);
  if (parts.size() != 3) throw InputError("--dists: expected start:stop:step in metres, got '" + text + "'");
  return {parse_number(parts[0], "--dists start"), parse_number(parts[1], "--dists stop"),
          parse_number(parts[2], "--dists step")};
}

std::vector<DataPair> parse_datasets(const std::string& text) {
  std::vector<DataPair> pairs;
  for (const auto& item : split_list(text)) {
    const auto colon = item.find(':');
    if (colon == std::string::npos) {
      pairs.push_back({item, item});
    } else {
      pairs.push_back({item.substr(0, colon), item.substr(colon + 1)});
    }
    if (pairs.back().model.empty() || pairs.back().query.empty()) {
      throw InputError("--datasets: '" + item + "' names no model or no query");
    }
  }
  if (pairs.empty()) throw InputError("--datasets: no data set given");
  return pairs;
}

bool parse_strategies(const std::string& text) {
  if (text != "default" && text != "all") {
    throw InputError("strategies must be 'default' or 'all' (got '" + text + "')");
  }
  return text == "all";
}

Experiment load_experiment(const std::string& path, const std::vector<std::string>& all_adapters) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot read the experiment file");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(path + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  if (!doc.is_object()) throw InputError(path + ": an experiment is a JSON object");
  static const std::set<std::string> known{
      "name", "description", "pairs", "grid", "real_pairs", "adapters", "searches", "strategies", "k", "dists", "repetitions",
      "build_repetitions", "rounds", "budget_seconds", "min_time_seconds", "threads", "neighbour_budget", "synthetic_points", "seed",
      "memory_limit_gib", "skip_larger_models", "cell_timeout_seconds"};
  for (const auto& item : doc.items()) {
    if (!known.count(item.key())) throw InputError(path + ": unknown field '" + item.key() + "'");
  }

  Experiment e;
  e.file = path;
  e.name = get<std::string>(doc, "name", path);
  if (doc.contains("description")) e.description = get<std::string>(doc, "description", path);
  if (doc.contains("grid")) {
    const auto& grid = doc["grid"];
    for (const auto& model : get<std::vector<std::string>>(grid, "models", path)) {
      for (const auto& query : get<std::vector<std::string>>(grid, "queries", path)) e.pairs.push_back({model, query});
    }
  }
  if (doc.contains("pairs")) {
    for (const auto& pair : doc["pairs"]) {
      e.pairs.push_back({get<std::string>(pair, "model", path), get<std::string>(pair, "query", path)});
    }
  }
  if (doc.contains("real_pairs")) {
    for (const auto& name : get<std::vector<std::string>>(doc, "real_pairs", path)) e.pairs.push_back({name, name});
  }
  if (!doc.contains("adapters") || doc["adapters"] == "all") {
    e.adapters = all_adapters;
  } else {
    e.adapters = get<std::vector<std::string>>(doc, "adapters", path);
  }
  if (doc.contains("searches")) e.searches = get<std::vector<std::string>>(doc, "searches", path);
  if (doc.contains("strategies")) e.every_strategy = parse_strategies(get<std::string>(doc, "strategies", path));
  if (doc.contains("k")) e.ks = get_whole_list(doc, "k", path);
  if (doc.contains("dists")) e.dists = parse_dists(get<std::string>(doc, "dists", path));
  if (doc.contains("repetitions")) e.repetitions = get_whole<int>(doc, "repetitions", path);
  if (doc.contains("build_repetitions")) e.build_repetitions = get_whole<int>(doc, "build_repetitions", path);
  if (doc.contains("rounds")) e.rounds = get_whole<int>(doc, "rounds", path);
  if (doc.contains("budget_seconds")) e.budget_s = get<double>(doc, "budget_seconds", path);
  if (doc.contains("min_time_seconds")) e.min_time_s = get<double>(doc, "min_time_seconds", path);
  if (doc.contains("threads")) e.threads = get_whole<int>(doc, "threads", path);
  if (doc.contains("neighbour_budget")) e.neighbour_budget = get_whole<std::size_t>(doc, "neighbour_budget", path);
  if (doc.contains("synthetic_points")) e.synthetic_points = get_whole<std::size_t>(doc, "synthetic_points", path);
  if (doc.contains("seed")) e.seed = get_whole<std::uint64_t>(doc, "seed", path);
  if (doc.contains("memory_limit_gib")) e.memory_limit_gib = get<double>(doc, "memory_limit_gib", path);
  if (doc.contains("cell_timeout_seconds")) e.cell_timeout_s = get<double>(doc, "cell_timeout_seconds", path);
  if (doc.contains("skip_larger_models")) e.skip_larger_models = get<bool>(doc, "skip_larger_models", path);
  return e;
}

void validate(const Experiment& e, const std::vector<std::string>& all_adapters) {
  if (e.pairs.empty()) throw InputError("experiment '" + e.name + "': no data sets");
  if (e.adapters.empty()) throw InputError("experiment '" + e.name + "': no adapters");
  for (const auto& name : e.adapters) {
    if (std::find(all_adapters.begin(), all_adapters.end(), name) == all_adapters.end()) {
      std::string known;
      for (const auto& a : all_adapters) known += (known.empty() ? "" : ", ") + a;
      throw InputError("unknown adapter '" + name + "' (built in: " + known + ")");
    }
  }
  for (const auto& search : e.searches) {
    if (search != "ranged" && search != "knn" && search != "radius") {
      throw InputError("unknown search '" + search + "' (expected ranged, knn or radius)");
    }
  }
  for (int k : e.ks) {
    if (k < 1) throw InputError("k must be at least 1 (got " + std::to_string(k) + ")");
  }
  if (e.ks.empty()) throw InputError("no k given");
  const auto& d = e.dists;
  if (!std::isfinite(d.step_m) || d.step_m <= 0.0) throw InputError("distance step must be > 0 m");
  if (!std::isfinite(d.start_m) || d.start_m < 0.0) throw InputError("distances must be >= 0 m");
  if (!std::isfinite(d.stop_m) || d.stop_m < d.start_m) throw InputError("distance stop must be >= start");
  if (d.count() > kMaxDistances) {
    throw InputError("distances " + number_text(d.start_m) + ":" + number_text(d.stop_m) + " by " +
                     number_text(d.step_m) + " m make more than " + std::to_string(long(kMaxDistances)) +
                     " values: is the step right?");
  }
  if (e.repetitions < 1 || e.repetitions > kMaxRepetitions) {
    throw InputError("repetitions must be from 1 to " + std::to_string(kMaxRepetitions));
  }
  if (e.build_repetitions < 1 || e.build_repetitions > kMaxRepetitions) {
    throw InputError("build repetitions must be from 1 to " + std::to_string(kMaxRepetitions));
  }
  if (e.rounds < 1 || e.rounds > kMaxRounds) {
    throw InputError("rounds must be from 1 to " + std::to_string(kMaxRounds));
  }
  // Finite: a results file's config holds them, and JSON has no infinity.
  if (!(e.budget_s > 0.0) || !std::isfinite(e.budget_s)) throw InputError("the time budget must be a finite > 0 s");
  if (!(e.min_time_s >= 0.0) || !std::isfinite(e.min_time_s)) {
    throw InputError("min_time_seconds must be a finite >= 0 s");
  }
  if (e.threads < 1 || e.threads > SearchIndex::kMaxThreads) {
    throw InputError("threads must be from 1 to " + std::to_string(SearchIndex::kMaxThreads));
  }
  if (!(e.cell_timeout_s > 0.0) || !std::isfinite(e.cell_timeout_s)) {
    throw InputError("the cell time-out must be a finite > 0 s");
  }
  if (e.synthetic_points < 1) throw InputError("synthetic data sets need at least 1 point");
  if (!std::isfinite(e.memory_limit_gib) || !(e.memory_limit_gib > 0.0)) {
    throw InputError("the memory limit must be > 0 GiB");
  }
}

}  // namespace nnb::sweep
