#include "runner.hpp"

#include "answer_size.hpp"
#include "isolation.hpp"
#include "memory.hpp"
#include "size_gate.hpp"

#include "nnb/registry.hpp"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <functional>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iomanip>
#include <new>
#include <numeric>
#include <set>
#include <sstream>
#include <utility>

#include <unistd.h>

namespace nnb::sweep {
namespace {

std::string seconds_text(double s) {
  std::ostringstream out;
  out << std::setprecision(3) << s;
  return out.str();
}

TimeStats stats_of(std::vector<double> samples) {
  TimeStats s;
  if (samples.empty()) return s;
  std::sort(samples.begin(), samples.end());
  const std::size_t n = samples.size();
  s.median_s = n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
  s.mean_s = std::accumulate(samples.begin(), samples.end(), 0.0) / static_cast<double>(n);
  s.min_s = samples.front();
  if (n > 1) {
    double sq = 0.0;
    for (double x : samples) sq += (x - s.mean_s) * (x - s.mean_s);
    s.stddev_s = std::sqrt(sq / static_cast<double>(n - 1));  // sample deviation, as Google Benchmark
  }
  return s;
}

double cpu_now_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Whether two exact answers to one cell agree: the same queries found, distance sums within rounding.
bool answers_agree(const Record& a, const Record& b) {
  const double tolerance = 1e-9 * std::max(std::abs(a.dist_sum_m), std::abs(b.dist_sum_m));
  return a.found == b.found && std::abs(a.dist_sum_m - b.dist_sum_m) <= tolerance;
}

// Compares exact adapters cell by cell with the first exact adapter that ran the same cell
// (brute force, being first in the registry, whenever it ran).
class Agreement {
 public:
  static std::string key(const Record& r) {
    std::ostringstream dist;
    if (r.max_dist_m) dist << std::setprecision(17) << *r.max_dist_m;
    return r.model + "|" + r.query + "|" + r.search + "|" + (r.k ? std::to_string(*r.k) : "-") + "|" +
           (r.max_dist_m ? dist.str() : "-");
  }
  void remember(const Record& r) {
    if (r.type == Record::Type::sweep && r.exact && r.skipped.empty()) reference_.emplace(key(r), r);
  }
  // Sets agrees/checked_against/disagreement; returns false on a disagreement.
  bool check(Record& r) {
    if (r.type != Record::Type::sweep || !r.exact || !r.skipped.empty()) return true;
    const auto [it, inserted] = reference_.emplace(key(r), r);
    const Record& ref = it->second;
    r.checked_against = ref.adapter;
    if (inserted) {
      r.agrees = true;
      return true;
    }
    const bool same = answers_agree(r, ref);
    r.agrees = same;
    if (!same) {
      std::ostringstream text;
      text << std::setprecision(17) << "found " << r.found << " vs " << ref.found << " (" << ref.adapter
           << "), dist_sum " << r.dist_sum_m << " m vs " << ref.dist_sum_m << " m";
      r.disagreement = text.str();
    }
    return same;
  }

 private:
  std::map<std::string, Record> reference_;
};

Record sweep_record(const DataPair& pair, const PlannedAdapter& adapter, const Group& group, const Cell& cell,
                    const LoadedData& data) {
  Record r;
  r.type = Record::Type::sweep;
  r.name = cell.name;
  r.model = pair.model;
  r.query = pair.query;
  r.n_points = static_cast<std::size_t>(data.models.at(pair.model).points.cols());
  r.n_queries = static_cast<std::size_t>(data.queries.at(pair.query).points.cols());
  r.adapter = adapter.name;
  r.exact = adapter.info.exact;
  r.search = to_string(group.kind);
  r.strategy = to_string(group.strategy);
  r.max_dist_m = cell.max_dist_m;
  r.k = group.k;
  return r;
}

// A call over the budget ends the cell's repetitions, unless it is the first and within twice the budget:
// a first call can be slow for reasons of its own (cold caches, first-touch page faults, the clock
// ramping up), and the series should not stop on it alone.
bool ends_repetitions(const std::vector<double>& wall, const Experiment& e) {
  if (wall.back() <= e.budget_s) return false;
  return wall.size() > 1 || wall.back() > 2.0 * e.budget_s;
}

// k a query, at most the points; none for radius search, which has no k.
std::size_t k_per_query(const Group& group, const Record& r) {
  return group.k ? std::min(static_cast<std::size_t>(*group.k), r.n_points) : 0;
}

// Returns the fastest repetition's wall time, seconds: what the budget judges. out is the unit's, its memory
// written before the calls: the kernel's first touch of a fresh page is the harness's cost, not the
// library's, and a cell timed once a round would otherwise pay it in every call, a radius search most. A
// call that outgrew that room is made again (call_within_room).
double run_cell(const SearchIndex& index, const Cloud& queries, const Group& group, const Cell& cell,
              const Experiment& e, std::size_t earlier_neighbours, Neighbours& out, Record& r) {
  std::size_t room = output_room(group.kind, k_per_query(group, r), r.n_queries, earlier_neighbours, out.total());
  touch_output(r.n_queries, room, out);
  const auto timed_call = [&] {
    const double cpu0 = cpu_now_s();
    const auto t0 = std::chrono::steady_clock::now();
    switch (group.kind) {
      case SearchKind::knn: index.knn(queries, *group.k, out); break;
      case SearchKind::radius: index.radius(queries, *cell.max_dist_m, out); break;
      case SearchKind::ranged: index.ranged(queries, *group.k, *cell.max_dist_m, out, group.strategy); break;
    }
    const auto t1 = std::chrono::steady_clock::now();
    return std::pair{std::chrono::duration<double>(t1 - t0).count(), cpu_now_s() - cpu0};
  };
  std::vector<double> wall, cpu;
  for (int rep = 0; rep < e.repetitions; ++rep) {
    const auto [wall_s, cpu_s] = call_within_room(timed_call, out, room);
    wall.push_back(wall_s);
    cpu.push_back(cpu_s);
    if (ends_repetitions(wall, e)) break;
    if (e.min_time_s > 0.0 && std::accumulate(wall.begin(), wall.end(), 0.0) >= e.min_time_s) break;
  }
  r.repetitions = static_cast<int>(wall.size());
  r.threads = index.threads_used();
  r.wall_each_s = wall;
  r.cpu_each_s = cpu;
  r.wall = stats_of(wall);
  r.cpu = stats_of(cpu);
  r.found = out.queries_with_neighbours();
  r.neighbours = out.total();
  double sum = 0.0;
  for (double sq : out.sq_dists) sum += std::sqrt(sq);
  r.dist_sum_m = sum;
  return *std::min_element(wall.begin(), wall.end());
}

}  // namespace

LoadedData load_data(const Experiment& e, const std::string& data_dir) {
  datasets::DataOptions options;
  options.data_dir = data_dir;
  options.synthetic_points = e.synthetic_points;
  options.seed = e.seed;
  LoadedData data;
  for (const auto& pair : e.pairs) {
    if (!data.models.count(pair.model)) {
      data.models.emplace(pair.model, datasets::resolve_cloud(pair.model, datasets::Role::model, options));
    }
    if (!data.queries.count(pair.query)) {
      data.queries.emplace(pair.query, datasets::resolve_cloud(pair.query, datasets::Role::query, options));
    }
  }
  return data;
}

namespace {

// A unit of the plan with its model cloud, as the runner takes it on.
struct Unit {
  const std::string& model_spec;
  const datasets::NamedCloud& model;
  const PlannedAdapter& adapter;
  const std::string& build;  // the build record's name
  const std::vector<PairWork>& work;
};

Unit unit_of(const PlanUnit& planned, const LoadedData& data) {
  return {planned.model, data.models.at(planned.model), *planned.adapter, planned.build, planned.work};
}

// Records of the unit still missing from the sink, the build's included.
std::size_t to_do(const PlanUnit& planned, const ResultsSink& sink) {
  const auto names = planned.cell_names();
  return static_cast<std::size_t>(std::count_if(names.begin(), names.end(), [&](const auto& n) { return !sink.has(n); }));
}

Record build_record(const Unit& unit) {
  Record b;
  b.type = Record::Type::build;
  b.name = unit.build;
  b.model = unit.model_spec;
  b.adapter = unit.adapter.name;
  b.exact = unit.adapter.info.exact;
  b.n_points = static_cast<std::size_t>(unit.model.points.cols());
  return b;
}

// The unit's records not yet in the sink, every one skipped for the same reason.
std::vector<Record> skipped_records(const Unit& unit, const std::string& reason, const LoadedData& data,
                                    const std::function<bool(const std::string&)>& recorded) {
  std::vector<Record> batch;
  if (!recorded(unit.build)) {
    batch.push_back(build_record(unit));
    batch.back().skipped = reason;
  }
  for (const auto& [pair, groups] : unit.work) {
    for (const auto& group : groups) {
      for (const auto& cell : group.cells) {
        if (recorded(cell.name)) continue;
        batch.push_back(sweep_record(*pair, unit.adapter, group, cell, data));
        batch.back().skipped = reason;
      }
    }
  }
  return batch;
}

// Construction: a fresh index per repetition; the last one answers the queries. Sets b's timings, or
// b.skipped when the build failed.
std::unique_ptr<SearchIndex> build_index(const Unit& unit, const Experiment& e, Record& b, double& slowest_s,
                                         Progress& progress) {
  std::unique_ptr<SearchIndex> index;
  try {
    std::vector<double> wall, cpu;
    const bool peak_resets = reset_peak_rss();
    const std::size_t rss_before = current_rss_bytes();
    for (int rep = 0; rep < e.build_repetitions; ++rep) {
      index.reset();
      auto fresh = make_adapter(unit.adapter.name);
      fresh->set_threads(e.threads);
      const double cpu0 = cpu_now_s();
      const auto t0 = std::chrono::steady_clock::now();
      fresh->build(unit.model.points);
      const auto t1 = std::chrono::steady_clock::now();
      cpu.push_back(cpu_now_s() - cpu0);
      wall.push_back(std::chrono::duration<double>(t1 - t0).count());
      index = std::move(fresh);
      if (e.skip_larger_models && wall.back() > e.budget_s) break;
    }
    // Without a resettable peak, the growth of the RSS the finished index holds.
    const std::size_t rss_after = peak_resets ? peak_rss_bytes() : current_rss_bytes();
    b.build_peak_rss_bytes = rss_after > rss_before ? rss_after - rss_before : 0;
    slowest_s = *std::max_element(wall.begin(), wall.end());
    b.repetitions = static_cast<int>(wall.size());
    b.wall_each_s = wall;
    b.cpu_each_s = cpu;
    b.wall = stats_of(wall);
    b.cpu = stats_of(cpu);
    b.index_bytes = index->index_bytes();
    b.threads = index->build_threads_used();
  } catch (const std::bad_alloc&) {
    b.skipped = "out of memory: std::bad_alloc building on " + std::to_string(b.n_points) + " points";
    index.reset();
    progress.loud("ERROR " + b.name + ": " + b.skipped);
  } catch (const std::exception& ex) {
    b.skipped = std::string("error: build failed: ") + ex.what();
    index.reset();
    progress.loud("ERROR " + b.name + ": " + ex.what());
  }
  return index;
}

// Fault injection for the isolation tests: NNB_SWEEP_CRASH_ADAPTER / NNB_SWEEP_HANG_ADAPTER make that
// adapter's first cell crash (SIGSEGV) or hang, as a faulty library would.
void inject_fault(const std::string& adapter) {
  const char* crash = std::getenv("NNB_SWEEP_CRASH_ADAPTER");
  if (crash && adapter == crash) std::raise(SIGSEGV);
  const char* hang = std::getenv("NNB_SWEEP_HANG_ADAPTER");
  if (hang && adapter == hang) {
    for (;;) ::pause();
  }
}

// Why the rest of a group is skipped after this cell: over the time or neighbour budget, or an error.
std::string reason_to_stop(const Record& r, const Cell& cell, double fastest_s, const Experiment& e) {
  const std::string dist_text = cell.max_dist_m ? " at max_dist " + cell.dist_label : "";
  if (r.skipped.empty() && fastest_s > e.budget_s) {
    return "over budget: " + seconds_text(fastest_s) + " s" + dist_text + " > " + seconds_text(e.budget_s) + " s";
  }
  if (!r.skipped.empty()) return r.skipped + dist_text;  // errors repeat: say it once
  if (r.neighbours > e.neighbour_budget) {
    return "over neighbour budget: " + std::to_string(r.neighbours) + " neighbours" + dist_text + " > " +
           std::to_string(e.neighbour_budget);
  }
  return "";
}

// Ranged search via_radius holds the whole radius answer before it keeps k a query: counted first (in
// bounded slices, untimed), a cell whose radius answer would pass the neighbour budget is not run.
std::string over_budget_behind(const SearchIndex& index, const Cloud& queries, const Group& group,
                               const Cell& cell, const Experiment& e) {
  if (group.kind != SearchKind::ranged || group.strategy != Strategy::via_radius) return "";
  const auto held = radius_answer_past_limit(index, queries, *cell.max_dist_m, e.neighbour_budget);
  if (!held) return "";
  return "over neighbour budget: over " + std::to_string(*held) + " neighbours > " +
         std::to_string(e.neighbour_budget) + " in the radius search behind via_radius";
}

struct SweepState {
  const Experiment& e;
  const LoadedData& data;
  Agreement& agreement;
  SizeGate& gate;
  Progress& progress;
  std::size_t disagreements = 0;  // found in this run
  std::set<std::string> settled_at_start;  // counted whole by the progress at the start
};

// Runs one cell; the larger distances of its group are recorded skipped in the same checkpoint when it
// went over a budget or failed. Returns the reason the group stops, empty when it goes on.
std::string sweep_cell(const Unit& unit, const DataPair& pair, const Group& group, std::size_t c,
                       const SearchIndex& index, Neighbours& out, SweepState& s, ResultsSink& sink) {
  const Cell& cell = group.cells[c];
  Record r = sweep_record(pair, unit.adapter, group, cell, s.data);
  s.progress.begin(cell.name);
  double fastest_s = 0.0;
  try {
    inject_fault(unit.adapter.name);
    const Cloud& queries = s.data.queries.at(pair.query).points;
    r.skipped = over_budget_behind(index, queries, group, cell, s.e);
    if (r.skipped.empty()) fastest_s = run_cell(index, queries, group, cell, s.e, 0, out, r);
  } catch (const std::bad_alloc&) {
    r.skipped = "out of memory: std::bad_alloc";
    s.progress.loud("ERROR " + cell.name + ": " + r.skipped);
  } catch (const std::exception& ex) {
    r.skipped = std::string("error: ") + ex.what();
    s.progress.loud("ERROR " + cell.name + ": " + ex.what());
  }
  s.gate.judge_cell(r, fastest_s);
  s.gate.observe(r);
  if (!r.skips_larger.empty()) s.progress.loud(unit.adapter.name + ": larger models will be skipped: " + r.skips_larger);
  if (!s.agreement.check(r)) s.progress.loud("DISAGREEMENT " + cell.name + ": " + r.disagreement);
  const std::string stop = reason_to_stop(r, cell, fastest_s, s.e);
  const std::string outcome =
      r.skipped.empty() ? seconds_text(r.wall.median_s) + " s, found " + std::to_string(r.found) : r.skipped;
  std::vector<Record> batch{std::move(r)};
  for (std::size_t later = c + 1; !stop.empty() && later < group.cells.size(); ++later) {
    if (sink.has(group.cells[later].name)) continue;
    batch.push_back(sweep_record(pair, unit.adapter, group, group.cells[later], s.data));
    batch.back().skipped = stop;
  }
  sink.add(batch);
  s.progress.end(1, outcome);
  if (batch.size() > 1) {
    s.progress.begin(group.cells.back().name);
    s.progress.end(batch.size() - 1, "skipped " + std::to_string(batch.size() - 1) + " cells: " + stop);
  }
  return stop;
}

// The unit's build and cells, as one process runs them (in the child when isolated).
void run_unit(const Unit& unit, SweepState& s, ResultsSink& sink) {
  s.progress.begin(unit.build);
  Record b = build_record(unit);
  double slowest_build_s = 0.0;
  const std::unique_ptr<SearchIndex> index = build_index(unit, s.e, b, slowest_build_s, s.progress);
  s.gate.judge_build(b, slowest_build_s);
  s.gate.observe(b);
  if (!b.skips_larger.empty()) s.progress.loud(unit.adapter.name + ": larger models will be skipped: " + b.skips_larger);
  if (!sink.has(unit.build)) {
    sink.add({b});
    s.progress.end(1, b.skipped.empty() ? "built in " + seconds_text(b.wall.median_s) + " s" : b.skipped);
  }
  Neighbours out;
  for (const auto& [pair, groups] : unit.work) {
    for (const auto& group : groups) {
      std::string stop = b.skipped;
      for (std::size_t c = 0; c < group.cells.size(); ++c) {
        if (sink.has(group.cells[c].name)) continue;
        if (!stop.empty()) {  // the build failed: every cell says why
          Record r = sweep_record(*pair, unit.adapter, group, group.cells[c], s.data);
          r.skipped = stop;
          s.progress.begin(group.cells[c].name);
          sink.add({r});
          s.progress.end(1, "skipped: " + stop);
          continue;
        }
        if (!(stop = sweep_cell(unit, *pair, group, c, *index, out, s, sink)).empty()) break;
      }
    }
  }
}

// The unit in a child process; its batches land in the sink here. When the child crashes or hangs, the
// cells it did not finish are recorded failed with the reason, and the sweep goes on.
void run_unit_isolated(const Unit& unit, SweepState& s, ResultsSink& sink) {
  std::set<std::string> received;
  const auto on_batch = [&](const std::vector<Record>& batch) {
    for (const auto& r : batch) {
      received.insert(r.name);
      s.disagreements += r.agrees && !*r.agrees;
      s.agreement.remember(r);
      s.gate.observe(r);
    }
    s.progress.advance(batch.size());
    sink.add(batch);
  };
  const std::string failure =
      run_in_child(sink, [&](ResultsSink& pipe) { run_unit(unit, s, pipe); }, on_batch, s.e.cell_timeout_s);
  if (failure == "interrupted") {
    sink.add({});  // writes the checkpoint and stops the run
    return;
  }
  if (failure.empty()) return;
  const std::string reason = failure + " in " + unit.adapter.name;
  s.progress.loud("ERROR " + unit.build + ": " + reason);
  const auto batch = skipped_records(unit, reason, s.data,
                                     [&](const std::string& name) { return sink.has(name) || received.count(name); });
  sink.add(batch);
  s.progress.advance(batch.size());
}

// Rounds after the first: each cell that ran, unless a call over the budget ended it, is timed again in a later
// pass over its model's units, and its calls join the cell's record; the answers must be those of the first round.

// Whether a cell's calls so far ended its timing: a call over the budget ends its rounds as it ends its
// repetitions within one (a 200 s call is not made three times).
bool ended_by_budget(const Record& r, const Experiment& e) {
  return r.type == Record::Type::sweep && !r.wall_each_s.empty() && ends_repetitions(r.wall_each_s, e);
}

// Whether the record takes part in this round: it ran, has fewer rounds than this one and the budget did not
// end it.
bool due_in_round(const Record* r, int round, const Experiment& e) {
  return r && r->skipped.empty() && r->rounds < round && !ended_by_budget(*r, e);
}

// old with fresh's timings added as one more round.
Record with_round(const Record& old, const Record& fresh) {
  Record merged = old;
  merged.wall_each_s.insert(merged.wall_each_s.end(), fresh.wall_each_s.begin(), fresh.wall_each_s.end());
  merged.cpu_each_s.insert(merged.cpu_each_s.end(), fresh.cpu_each_s.begin(), fresh.cpu_each_s.end());
  merged.repetitions += fresh.repetitions;
  merged.wall = stats_of(merged.wall_each_s);
  merged.cpu = stats_of(merged.cpu_each_s);
  merged.rounds = old.rounds + 1;
  return merged;
}

// An exact adapter must answer every round alike; a differing round marks the cell as disagreeing.
bool same_answers(const Record& old, const Record& fresh, Record& merged) {
  if (!old.exact || (answers_agree(fresh, old) && fresh.neighbours == old.neighbours)) return true;
  std::ostringstream text;
  text << std::setprecision(17) << "round " << merged.rounds << ": found " << fresh.found << " vs " << old.found
       << ", dist_sum " << fresh.dist_sum_m << " m vs " << old.dist_sum_m << " m in the first round";
  merged.agrees = false;
  merged.disagreement = text.str();
  return false;
}

// The unit's records (its build's included) that meet a condition.
std::size_t count_records(const PlanUnit& planned, const ResultsSink& sink,
                          const std::function<bool(const Record*)>& condition) {
  const auto names = planned.cell_names();
  return static_cast<std::size_t>(
      std::count_if(names.begin(), names.end(), [&](const auto& n) { return condition(sink.find(n)); }));
}

// The unit's build and its cells due in this round, as the child runs them.
void run_unit_round(const Unit& unit, int round, SweepState& s, ResultsSink& sink) {
  const std::string label = "round " + std::to_string(round) + ": ";
  s.progress.begin(unit.build);
  Record b = build_record(unit);
  double slowest_build_s = 0.0;
  const std::unique_ptr<SearchIndex> index = build_index(unit, s.e, b, slowest_build_s, s.progress);
  if (!index) return;  // build_index said why; the cells keep their earlier rounds
  if (const Record* old = sink.find(unit.build); due_in_round(old, round, s.e)) {
    sink.add({with_round(*old, b)});
    s.progress.end(1, label + "built in " + seconds_text(b.wall.median_s) + " s");
  }
  Neighbours out;
  for (const auto& [pair, groups] : unit.work) {
    for (const auto& group : groups) {
      for (const auto& cell : group.cells) {
        const Record* old = sink.find(cell.name);
        if (!due_in_round(old, round, s.e)) continue;
        s.progress.begin(cell.name);
        Record fresh = sweep_record(*pair, unit.adapter, group, cell, s.data);
        try {
          run_cell(*index, s.data.queries.at(pair->query).points, group, cell, s.e, old->neighbours, out, fresh);
        } catch (const std::exception& ex) {
          s.progress.loud("ERROR " + label + cell.name + ": " + ex.what());
          continue;
        }
        Record merged = with_round(*old, fresh);
        if (!same_answers(*old, fresh, merged)) s.progress.loud("DISAGREEMENT " + cell.name + ": " + merged.disagreement);
        sink.add({merged});
        s.progress.end(1, label + seconds_text(fresh.wall.median_s) + " s");
      }
    }
  }
}

// The unit's round in a child process. A crash or hang costs this round's calls of the cells it did not
// finish, which keep their earlier rounds (and --resume runs them again).
void run_unit_round_isolated(const Unit& unit, int round, SweepState& s, ResultsSink& sink) {
  const auto on_batch = [&](const std::vector<Record>& batch) {
    for (const auto& r : batch) s.disagreements += r.agrees && !*r.agrees;
    s.progress.advance(batch.size());
    sink.add(batch);
  };
  const std::string failure = run_in_child(
      sink, [&](ResultsSink& pipe) { run_unit_round(unit, round, s, pipe); }, on_batch, s.e.cell_timeout_s);
  if (failure == "interrupted") {
    sink.add({});
    return;
  }
  if (!failure.empty()) {
    s.progress.loud("ERROR " + unit.build + " in round " + std::to_string(round) + ": " + failure + " in " +
                    unit.adapter.name);
  }
}

// The unit's first round: gated (over the memory limit or closed by a smaller model: the build and all its
// cells recorded skipped) or run in a child process.
void run_first_round(const PlanUnit& planned, SweepState& s, ResultsSink& sink) {
  if (to_do(planned, sink) == 0) return;
  const Unit unit = unit_of(planned, s.data);
  if (const std::string gated = s.gate.reason_to_skip(unit.adapter.name, unit.model_spec, unit.model.points.cols());
      !gated.empty()) {
    const auto batch = skipped_records(unit, gated, s.data, [&](const std::string& name) { return sink.has(name); });
    s.progress.begin(unit.build);
    sink.add(batch);
    s.progress.end(batch.size(), "skipped " + std::to_string(batch.size()) + " cells: " + gated);
    return;
  }
  run_unit_isolated(unit, s, sink);
}

// A later round of the unit: its cells that ran and lack this round timed again.
void run_later_round(const PlanUnit& planned, int round, SweepState& s, ResultsSink& sink) {
  s.progress.advance(count_records(planned, sink, [&](const Record* r) {
    return r && settled_in_round(*r, round, s.e) && s.settled_at_start.count(r->name) == 0;
  }));
  if (count_records(planned, sink, [&](const Record* r) { return due_in_round(r, round, s.e); }) > 0) {
    run_unit_round_isolated(unit_of(planned, s.data), round, s, sink);
  }
}

}  // namespace

bool settled(const Record& r, const Experiment& e) { return !r.skipped.empty() || ended_by_budget(r, e); }

std::size_t rounds_counted(const Record& r, const Experiment& e) {
  return static_cast<std::size_t>(settled(r, e) ? e.rounds : std::min(r.rounds, e.rounds));
}

bool settled_in_round(const Record& r, int round, const Experiment& e) {
  return !r.skipped.empty() || (ended_by_budget(r, e) && r.rounds < round);
}

std::size_t run_experiment(const Experiment& e, const LoadedData& data, const SweepPlan& plan,
                           const std::vector<Record>& previous, ResultsSink& sink, Progress& progress,
                           const UnitFilter& in_shard) {
  Agreement agreement;
  SizeGate gate(e.memory_limit_gib * 1024.0 * 1024.0 * 1024.0, e.skip_larger_models, e.budget_s);
  for (const auto& r : previous) {
    agreement.remember(r);
    gate.observe(r);
  }
  SweepState state{e, data, agreement, gate, progress, 0, {}};
  for (const auto& r : previous) {
    if (settled(r, e)) state.settled_at_start.insert(r.name);
  }
  std::vector<const PlanUnit*> model_units;
  // A model's rounds run before the next model's, so that a cell's rounds lie minutes apart, not a whole
  // plan apart: a run cut into sittings (or resumed on another machine) splits at most one model's calls.
  auto run_model = [&] {
    for (const PlanUnit* planned : model_units) run_first_round(*planned, state, sink);
    for (int round = 2; round <= e.rounds; ++round) {
      for (const PlanUnit* planned : model_units) run_later_round(*planned, round, state, sink);
    }
    model_units.clear();
  };
  for (const auto& planned : plan.units()) {
    if (in_shard && !in_shard(planned.model, planned.adapter->name)) continue;
    if (!model_units.empty() && model_units.front()->model != planned.model) run_model();
    model_units.push_back(&planned);
  }
  run_model();
  return state.disagreements;
}

}  // namespace nnb::sweep
