// nns_query: answer one query set with one adapter and write every neighbour found as CSV.
// The tool a user reaches for to check any library's answer, and its speed, by hand.
#include "adapter_json.hpp"
#include "answer_size.hpp"
#include "cli_common.hpp"
#include "machine_json.hpp"
#include "results_json.hpp"

#include "nnb/datasets/catalog.hpp"
#include "nnb/registry.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <cmath>
#include <numeric>
#include <optional>
#include <vector>

namespace {

// Most calls --repeat may ask for (each call's time is kept for the median).
constexpr int kMaxRepeat = 10000;

struct Options {
  std::string model, query, adapter = "brute_force", search = "ranged", strategy, out, stats, describe_pairs;
  int k = 1;
  double max_dist_m = 0.1;
  int repeat = 1;
  int threads = 1;
  std::size_t max_neighbours = 10'000'000;
  std::vector<std::string> params;
  nnb::datasets::DataOptions data;
  bool list = false, json = false, check = false;
};

// --strategy for ranged search (one the adapter offers), else the adapter's default for the kind.
nnb::Strategy chosen_strategy(const Options& opt, nnb::SearchKind kind, const nnb::AdapterInfo& info) {
  if (opt.strategy.empty()) return info.strategy(kind);
  if (kind != nnb::SearchKind::ranged) throw nnb::InputError("--strategy chooses how ranged search is answered");
  const nnb::Strategy strategy = nnb::parse_strategy(opt.strategy);
  nnb::check_offered(info, kind, strategy);  // before the clouds are loaded
  return strategy;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One CSV row per neighbour, sorted by query then distance (then index, for ties); metres, not squared.
std::string to_csv(const nnb::Neighbours& found) {
  std::string text = "query,neighbor,distance\n";
  std::vector<std::pair<double, nnb::PointIndex>> row;
  char number[64];
  for (std::size_t q = 0; q < found.n_queries(); ++q) {
    row.clear();
    for (std::size_t i = found.offsets[q]; i < found.offsets[q + 1]; ++i) {
      row.emplace_back(found.sq_dists[i], found.indices[i]);
    }
    std::sort(row.begin(), row.end());
    for (const auto& [sq, index] : row) {
      const auto end = std::to_chars(number, number + sizeof number, std::sqrt(sq)).ptr;
      text += std::to_string(q) + ',' + std::to_string(index) + ',' + std::string(number, end) + '\n';
    }
  }
  return text;
}

// Whether two paths name one file, existing or not (links followed).
bool same_path(const std::string& a, const std::string& b) {
  std::error_code error_a, error_b;
  const auto path_a = std::filesystem::weakly_canonical(a, error_a);
  const auto path_b = std::filesystem::weakly_canonical(b, error_b);
  return !error_a && !error_b && path_a == path_b;
}

// Outputs are checked before any work: a bad path fails at once, and an input file is never replaced.
void check_outputs(const Options& opt, const std::vector<nnb::datasets::NamedCloud>& clouds) {
  std::vector<std::string> inputs;
  for (const auto& cloud : clouds) {
    if (cloud.kind == "file") inputs.push_back(cloud.source);
  }
  if (!opt.out.empty() && opt.out != "-") nnb::files::check_output_path(opt.out, inputs);
  if (!opt.stats.empty()) nnb::files::check_output_path(opt.stats, inputs);
  if (!opt.out.empty() && !opt.stats.empty() && same_path(opt.out, opt.stats)) {
    throw nnb::InputError("--out and --stats are the same file, " + opt.out + ": the one would replace the other");
  }
}

// Every neighbour becomes a CSV row, so the answer is bounded before it is computed: k-NN and ranged by
// queries x k, radius (unbounded by k) by counting it first in bounded slices.
// Ranged search via_radius holds the whole radius answer before it keeps k a query, so it is counted as radius.
void check_neighbour_budget(const Options& opt, nnb::SearchKind kind, nnb::Strategy strategy,
                            const nnb::SearchIndex& index, const nnb::Cloud& queries) {
  const double n_queries = static_cast<double>(queries.cols());
  const double n_model = static_cast<double>(index.model_size());
  const auto refuse = [&](const std::string& what) {
    throw nnb::InputError(what + " exceeds --max-neighbours " + std::to_string(opt.max_neighbours) +
                          ": lower --k or --max-dist, or raise --max-neighbours");
  };
  const bool radius_behind = kind == nnb::SearchKind::ranged && strategy == nnb::Strategy::via_radius;
  if (kind != nnb::SearchKind::radius && !radius_behind) {
    if (n_queries * std::min<double>(opt.k, n_model) > static_cast<double>(opt.max_neighbours)) {
      refuse(std::to_string(queries.cols()) + " queries x k " + std::to_string(opt.k));
    }
    return;
  }
  if (const auto held = nnb::radius_answer_past_limit(index, queries, opt.max_dist_m, opt.max_neighbours)) {
    refuse(std::string(radius_behind ? "the radius search behind via_radius" : "the radius search's answer") +
           " (over " + std::to_string(*held) + " neighbours)");
  }
}

// Runs the search opt.repeat times; returns the median time of a call, seconds.
double timed_searches(const Options& opt, nnb::SearchKind kind, nnb::Strategy strategy, const nnb::SearchIndex& index,
                      const nnb::Cloud& queries, nnb::Neighbours& found) {
  std::vector<double> query_seconds;
  for (int r = 0; r < opt.repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    index.search(kind, queries, opt.k, opt.max_dist_m, found, strategy);
    query_seconds.push_back(seconds_since(start));
  }
  std::sort(query_seconds.begin(), query_seconds.end());
  return query_seconds[query_seconds.size() / 2];
}

// The neighbours' squared distances of query q, ascending.
std::vector<double> sorted_sq_dists(const nnb::Neighbours& found, std::size_t q) {
  std::vector<double> sq(found.sq_dists.begin() + static_cast<std::ptrdiff_t>(found.offsets[q]),
                         found.sq_dists.begin() + static_cast<std::ptrdiff_t>(found.offsets[q + 1]));
  std::sort(sq.begin(), sq.end());
  return sq;
}

// How many queries got neighbours at the distances brute force finds (compared by distance: ties make
// indices differ between correct answers): what an approximate adapter gets right.
std::size_t queries_agreeing_with_brute_force(const Options& opt, nnb::SearchKind kind, const nnb::Cloud& model,
                                              const nnb::Cloud& queries, const nnb::Neighbours& found) {
  const auto reference = nnb::make_adapter("brute_force", {});
  reference->build(model);
  nnb::Neighbours expected;
  reference->search(kind, queries, opt.k, opt.max_dist_m, expected);
  std::size_t agreeing = 0;
  for (std::size_t q = 0; q < found.n_queries(); ++q) {
    const std::vector<double> got = sorted_sq_dists(found, q), want = sorted_sq_dists(expected, q);
    agreeing += std::equal(got.begin(), got.end(), want.begin(), want.end(), [](double a, double b) {
      return std::abs(a - b) <= 1e-9 * std::max(a, b);
    });
  }
  return agreeing;
}

void write_stats(const Options& opt, const nnb::SearchIndex& index, nnb::Strategy strategy,
                 const nnb::datasets::NamedCloud& model, const nnb::datasets::NamedCloud& query, double build_seconds,
                 double median_seconds, const nnb::Neighbours& found, std::optional<std::size_t> agreeing) {
  const nnb::AdapterInfo& info = index.info();
  nlohmann::json stats = {
      {"adapter", info.name},
      {"library", info.library},
      {"library_version", info.version},
      {"strategy", nnb::to_string(strategy)},
      {"params", info.params},
      {"search", opt.search},
      {"k", opt.k},
      {"max_dist_m", opt.max_dist_m},
      {"model", model.name},
      {"model_points", model.points.cols()},
      {"query", query.name},
      {"query_points", query.points.cols()},
      {"build_seconds", build_seconds},
      {"query_seconds", median_seconds},
      {"repeat", opt.repeat},
      {"threads", index.threads_used()},
      {"found", found.queries_with_neighbours()},
      {"neighbours", found.total()},
      {"index_bytes", index.index_bytes()},
      {"build_type", nnb::cli::build_type()},
  };
  if (agreeing) stats["agreeing_with_brute_force"] = *agreeing;
  nnb::files::write_file_atomically(opt.stats, stats.dump(2) + "\n");
}

// Every adapter built in, by name, as a results file's context 'adapters' holds it: plots/table1.py makes
// Table 1 from this.
void print_adapter_json() {
  nlohmann::ordered_json adapters = nlohmann::ordered_json::object();
  for (const auto& entry : nnb::adapter_registry()) {
    const auto index = entry.make({});
    adapters[index->info().name] = nnb::bench::adapter_metadata(index->info());
  }
  std::cout << adapters.dump(2) << "\n";
}

// A real pair's scan as loaded here, in run_sweep's context.datasets form plus the dropped points by kind,
// the units of the file and, for the query, the pose file it is placed by.
nlohmann::ordered_json scan_entry(const nnb::datasets::RealPair& pair, nnb::datasets::Role role,
                                  const nnb::datasets::DataOptions& data) {
  const auto cloud = nnb::datasets::load_pair_scan(pair, role, data);
  const bool is_query = role == nnb::datasets::Role::query;
  nlohmann::ordered_json entry{{"spec", pair.name}, {"role", is_query ? "query" : "model"}, {"kind", cloud.kind},
                               {"file", std::filesystem::path(cloud.source).filename().string()},
                               {"sha256", cloud.sha256}, {"points", cloud.points.cols()}, {"n_read", cloud.n_read},
                               {"n_dropped", cloud.n_dropped}, {"n_non_finite", cloud.n_non_finite},
                               {"n_zero", cloud.n_zero}, {"units", pair.units}};
  if (is_query) {
    entry["placed_by"] = pair.reference ? pair.reference->file : pair.initial ? pair.initial->file : "identity";
  }
  return entry;
}

// Every real pair loaded through the loaders, written as a results file whose context lists each scan:
// the README's data-set table reads it, so that it needs no data to be checked.
void describe_real_pairs(const Options& opt) {
  nnb::files::check_output_path(opt.describe_pairs, {});
  nlohmann::ordered_json context;
  nnb::bench::put_machine_and_build(context, nnb::bench::read_machine_info(), nnb::bench::read_build_info(),
                                    "nns_query");
  context["data_dir"] = opt.data.data_dir.empty() ? nnb::datasets::default_data_dir() : opt.data.data_dir;
  context["datasets"] = nlohmann::ordered_json::array();
  for (const auto& pair : nnb::datasets::real_pairs()) {
    for (const auto role : {nnb::datasets::Role::model, nnb::datasets::Role::query}) {
      context["datasets"].push_back(scan_entry(pair, role, opt.data));
    }
  }
  nnb::bench::put_run(context, nnb::bench::read_run_info());  // the wall time and load now the loading is done
  nnb::files::write_file_atomically(opt.describe_pairs, nnb::bench::results::file_text(context, {}));
  std::cerr << "nns_query: " << context["datasets"].size() << " scans described in " << opt.describe_pairs << "\n";
}

int run(const Options& opt) {
  if (opt.list && opt.json) {
    print_adapter_json();
    return 0;
  }
  if (opt.list) {
    nnb::cli::print_adapter_list(std::cout);
    return 0;
  }
  if (!opt.describe_pairs.empty()) {
    describe_real_pairs(opt);
    return 0;
  }
  if (opt.model.empty() || opt.query.empty()) throw nnb::InputError("--model and --query are required");
  if (opt.repeat < 1 || opt.repeat > kMaxRepeat) {
    throw nnb::InputError("--repeat must be from 1 to " + std::to_string(kMaxRepeat));
  }
  const nnb::SearchKind kind = nnb::parse_search_kind(opt.search);
  auto index = nnb::make_adapter(opt.adapter, nnb::cli::parse_params(opt.params));
  const nnb::Strategy strategy = chosen_strategy(opt, kind, index->info());
  index->set_threads(opt.threads);
  nnb::cli::warn_if_not_release(std::cerr);

  const auto model = nnb::datasets::resolve_cloud(opt.model, nnb::datasets::Role::model, opt.data);
  const auto query = nnb::datasets::resolve_cloud(opt.query, nnb::datasets::Role::query, opt.data);
  std::cerr << "nns_query: model " << model.name << ": " << model.points.cols() << " points (" << model.n_dropped
            << " invalid dropped); query " << query.name << ": " << query.points.cols() << " points ("
            << query.n_dropped << " invalid dropped)\n";

  check_outputs(opt, {model, query});

  const auto start = std::chrono::steady_clock::now();
  index->build(model.points);
  const double build_seconds = seconds_since(start);
  check_neighbour_budget(opt, kind, strategy, *index, query.points);

  nnb::Neighbours found;
  const double median_seconds = timed_searches(opt, kind, strategy, *index, query.points, found);

  const std::string csv = to_csv(found);
  if (opt.out.empty() || opt.out == "-") {
    std::cout << csv;
  } else {
    nnb::files::write_file_atomically(opt.out, csv);
  }
  std::optional<std::size_t> agreeing;
  if (opt.check) {
    agreeing = queries_agreeing_with_brute_force(opt, kind, model.points, query.points, found);
    std::cerr << "nns_query: check: " << *agreeing << " of " << found.n_queries()
              << " queries have the neighbour distances brute force finds\n";
  }
  if (!opt.stats.empty()) {
    write_stats(opt, *index, strategy, model, query, build_seconds, median_seconds, found, agreeing);
  }
  std::cerr << "nns_query: " << opt.adapter << " " << opt.search << ": " << found.queries_with_neighbours() << " of "
            << found.n_queries() << " queries found a neighbour; build " << build_seconds << " s, query "
            << median_seconds << " s (median of " << opt.repeat << ", " << index->threads_used() << " thread"
            << (index->threads_used() == 1 ? "" : "s") << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  nnb::bench::mark_run_start(argc, argv);
  Options opt;
  CLI::App app{"nns_query: answer a query set with one adapter; writes CSV query,neighbor,distance (metres)"};
  auto* list = app.add_flag("--list", opt.list, "Print the adapters built in and exit");
  app.add_flag("--json", opt.json,
               "With --list: print every adapter's declared metadata as JSON, as a results file's context "
               "'adapters' holds it (plots/table1.py --from-registry makes Table 1 from it)")
      ->needs(list);
  auto* describe = app.add_option("--describe-real-pairs", opt.describe_pairs,
                 "Load every real pair and write its scans' point counts (kept, dropped by kind) as JSON to this file");
  app.add_option("--model", opt.model, "Model cloud: a file, a shape (hollow_sphere, ...) or a real pair name")
      ->excludes(describe);
  app.add_option("--query", opt.query, "Query cloud: a file, a shape, or a real pair (its query scan at its pose)")
      ->excludes(describe);
  app.add_option("--adapter", opt.adapter, "Adapter name (see --list)")->capture_default_str();
  app.add_option("--search", opt.search, "knn, radius or ranged")->capture_default_str();
  app.add_option("--strategy", opt.strategy,
                 "How ranged search is answered: native, native_unpruned, via_knn or via_radius (default: the "
                 "adapter's own; --list shows what each offers)");
  app.add_option("--k", opt.k, "Neighbours per query (knn, ranged)")->capture_default_str();
  app.add_option("--max-dist", opt.max_dist_m, "Maximal distance / radius in metres")->capture_default_str();
  app.add_option("--param", opt.params, "Adapter parameter NAME=VALUE (repeatable), e.g. bucket_size=5");
  app.add_option("--out", opt.out, "CSV output file (default: standard output)");
  app.add_option("--threads", opt.threads,
                 "Threads each search may use (adapters that cannot share an index use one; the stats say how many)")
      ->check(CLI::Range(1, nnb::SearchIndex::kMaxThreads));
  app.add_option("--repeat", opt.repeat, "Answer the query set N times (1 to 10000); query_seconds is the median")
      ->capture_default_str();
  app.add_option("--stats", opt.stats, "Write JSON statistics to this file");
  app.add_flag("--check", opt.check,
               "Also search with brute_force and count the queries whose neighbours are at the same distances "
               "(stderr; agreeing_with_brute_force in --stats)");
  app.add_option("--max-neighbours", opt.max_neighbours,
                 "Refuse a search whose answer would hold more neighbours (CSV rows; for ranged search via_radius, "
                 "the radius search's answer it keeps k a query of) than this")
      ->capture_default_str();
  app.add_option("--data-dir", opt.data.data_dir, nnb::cli::kDataDirHelp)->check(CLI::ExistingDirectory);
  app.add_option("--points", opt.data.synthetic_points, "Points per synthetic set")->capture_default_str();
  app.add_option("--seed", opt.data.seed, "Seed of the synthetic sets")->capture_default_str();
  if (const auto code = nnb::cli::parse_command_line(app, argc, argv, "nns_query")) return *code;
  return nnb::cli::run_reporting_errors("nns_query", [&] { return run(opt); });
}
