#include "nnb/search_index.hpp"

#include "nnb/worker_pool.hpp"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

namespace nnb {

const char* to_string(SearchKind kind) {
  switch (kind) {
    case SearchKind::knn: return "knn";
    case SearchKind::radius: return "radius";
    case SearchKind::ranged: return "ranged";
  }
  return "?";
}

const char* to_string(Strategy strategy) {
  switch (strategy) {
    case Strategy::native: return "native";
    case Strategy::native_unpruned: return "native_unpruned";
    case Strategy::via_knn: return "via_knn";
    case Strategy::via_radius: return "via_radius";
    case Strategy::via_box: return "via_box";
    case Strategy::unsupported: return "unsupported";
  }
  return "?";
}

const char* to_string(Concurrency concurrency) {
  switch (concurrency) {
    case Concurrency::single: return "single";
    case Concurrency::queries: return "queries";
    case Concurrency::library: return "library";
  }
  return "?";
}

SearchKind parse_search_kind(const std::string& text) {
  if (text == "knn") return SearchKind::knn;
  if (text == "radius") return SearchKind::radius;
  if (text == "ranged") return SearchKind::ranged;
  throw InputError("unknown search kind '" + text + "' (expected knn, radius or ranged)");
}

Strategy parse_strategy(const std::string& text) {
  for (const Strategy s : {Strategy::native, Strategy::native_unpruned, Strategy::via_knn, Strategy::via_radius,
                           Strategy::via_box, Strategy::unsupported}) {
    if (text == to_string(s)) return s;
  }
  throw InputError("unknown strategy '" + text + "' (expected native, native_unpruned, via_knn, via_radius or via_box)");
}

void check_offered(const AdapterInfo& info, SearchKind kind, Strategy strategy) {
  if (info.offers(kind, strategy)) return;
  std::string names;
  for (const Strategy s : info.strategies(kind)) names += (names.empty() ? "" : ", ") + std::string(to_string(s));
  throw InputError(info.name + " does not answer " + to_string(kind) + " search " + to_string(strategy) +
                   " (it offers " + names + ")");
}

Strategy AdapterInfo::strategy(SearchKind kind) const {
  switch (kind) {
    case SearchKind::knn: return knn;
    case SearchKind::radius: return radius;
    case SearchKind::ranged: return ranged;
  }
  return knn;
}

bool AdapterInfo::offers(SearchKind kind, Strategy s) const {
  if (s == strategy(kind)) return s != Strategy::unsupported;
  if (kind != SearchKind::ranged || ranged == Strategy::unsupported) return false;
  if (s == Strategy::via_knn) return knn != Strategy::unsupported;
  if (s == Strategy::via_radius) return radius == Strategy::native || radius == Strategy::via_box;
  return false;
}

std::vector<Strategy> AdapterInfo::strategies(SearchKind kind) const {
  std::vector<Strategy> all{strategy(kind)};
  for (const Strategy s : {Strategy::via_knn, Strategy::via_radius}) {
    if (s != all.front() && offers(kind, s)) all.push_back(s);
  }
  return all;
}

namespace {

void check_k(const std::string& adapter, int k) {
  if (k < 1) throw InputError(adapter + ": k must be at least 1 (got " + std::to_string(k) + ")");
}

void check_distance(const std::string& adapter, const char* what, double value_m) {
  if (!std::isfinite(value_m) || value_m < 0.0) {
    std::ostringstream msg;
    msg << adapter << ": " << what << " must be a finite distance >= 0 m (got " << value_m << ")";
    throw InputError(msg.str());
  }
}

}  // namespace

void SearchIndex::build(const Cloud& model) {
  if (model.cols() == 0) throw InputError(info_.name + ": the model cloud is empty, nothing to search");
  if (static_cast<std::uint64_t>(model.cols()) >= std::numeric_limits<PointIndex>::max()) {
    throw InputError(info_.name + ": the model cloud has too many points for 32-bit indices");
  }
  if (const auto bad = first_non_finite(model); bad >= 0) {
    throw InputError(info_.name + ": model point " + std::to_string(bad) + " has a non-finite coordinate");
  }
  check_coordinate_range(model, info_.name + ": model cloud");
  model_size_ = 0;
  do_build(model);
  model_size_ = static_cast<std::size_t>(model.cols());
}

void SearchIndex::check_queries(const Cloud& queries) const {
  if (const auto bad = first_non_finite(queries); bad >= 0) {
    throw InputError(info_.name + ": query point " + std::to_string(bad) + " has a non-finite coordinate");
  }
  check_coordinate_range(queries, info_.name + ": query cloud");
}

// check_queries with the coordinates' check shared by a team: a query out of range (or not finite) in any
// member's share makes member 0 run check_queries alone, so the message is the one a single thread gives.
void SearchIndex::check_queries_on(const Team& team, const Cloud& queries, std::atomic<bool>& out_of_range) const {
  team.phase([&] {
    const std::pair<std::size_t, std::size_t> mine = team.share(static_cast<std::size_t>(queries.cols()));
    const auto first = static_cast<Eigen::Index>(mine.first), last = static_cast<Eigen::Index>(mine.second);
    if (first_out_of_range(queries, first, last) >= 0) out_of_range.store(true, std::memory_order_relaxed);
  });
  team.phase([&] {
    if (team.member() == 0 && out_of_range.load(std::memory_order_relaxed)) check_queries(queries);
  });
}

void SearchIndex::check_supported(SearchKind kind) const {
  if (info_.strategy(kind) == Strategy::unsupported) {
    throw InputError(info_.name + " does not answer " + to_string(kind) + " search");
  }
}

// No query has more than model_size_ neighbours: passing a larger k on would only make libraries reserve
// queries x k entries (gigabytes for a mistyped k) for the same answer.
int SearchIndex::useful_k(int k) const {
  return static_cast<int>(std::min(static_cast<std::size_t>(k), model_size_));
}

void SearchIndex::set_threads(int threads) {
  if (threads < 1 || threads > kMaxThreads) {
    throw InputError(info_.name + ": threads must be from 1 to " + std::to_string(kMaxThreads) + " (got " +
                     std::to_string(threads) + ")");
  }
  threads_ = threads;
}

namespace {

// Where the slices of n queries for `threads` threads begin (and, last, n). The cost of a query varies along
// a scan (dense near the scanner, empty far from it), so equal halves leave one thread idle; slices taken
// in turn even the load out, and each is still a run of consecutive queries (scan order kept for the
// structures that exploit it). Each slice is a 2 x threads-th of what is left (guided scheduling): the
// first are large, the last small, so the threads finish together (with 16 equal slices, the last one
// kept the other thread waiting a quarter of a batch's time).
std::vector<Eigen::Index> slice_starts(Eigen::Index n, int threads, Eigen::Index smallest) {
  std::vector<Eigen::Index> starts{0};
  while (starts.back() < n) {
    const Eigen::Index left = n - starts.back();
    starts.push_back(starts.back() + std::min(left, std::max(smallest, left / (2 * threads))));
  }
  return starts;
}

// Takes slices in turn until none is left: slice s holds the queries starts[s] to starts[s + 1] of the
// order (of the batch when order is empty); its rows go to rows[s], and member to answered_by[s].
template <class Answer>
void answer_slices(const Cloud& queries, const std::vector<Eigen::Index>& starts, const std::vector<PointIndex>& order,
                   const Answer& answer, int member, std::atomic<std::size_t>& next, std::vector<Neighbours>& rows,
                   std::vector<int>& answered_by) {
  for (std::size_t s = next++; s < rows.size(); s = next++) {
    const Eigen::Index first = starts[s], last = starts[s + 1];
    Cloud slice(3, last - first);
    for (Eigen::Index i = first; i < last; ++i)
      slice.col(i - first) = queries.col(order.empty() ? i : order[static_cast<std::size_t>(i)]);
    Neighbours own;  // filled on this thread's stack: rows[] side by side would share cache lines
    answer(slice, first, own);
    if (own.n_queries() != static_cast<std::size_t>(last - first)) {
      throw std::logic_error("a slice of " + std::to_string(last - first) + " queries got " +
                             std::to_string(own.n_queries()) + " rows");
    }
    rows[s] = std::move(own);
    answered_by[s] = member;
  }
}

// Puts the slices' rows into out (its offsets already sized) in the caller's order, each member those of the
// slices it answered (still in its cache), in three phases: the row lengths where their queries belong,
// their sums into offsets (member 0), then the rows themselves.
void return_rows(const Team& team, const std::vector<Eigen::Index>& starts, const std::vector<PointIndex>& order,
                 const std::vector<Neighbours>& rows, const std::vector<int>& answered_by, Neighbours& out) {
  const auto query_at = [&](std::size_t position) { return order.empty() ? position : std::size_t(order[position]); };
  const auto each_slice_of_mine = [&](auto&& slice_work) {
    for (std::size_t s = 0; s < rows.size(); ++s) {
      if (answered_by[s] == team.member()) slice_work(static_cast<std::size_t>(starts[s]), rows[s]);
    }
  };
  team.phase([&] {
    each_slice_of_mine([&](std::size_t first, const Neighbours& slice) {
      for (std::size_t j = 0; j < slice.n_queries(); ++j) out.offsets[query_at(first + j) + 1] = slice.count(j);
    });
  });
  team.phase([&] {
    if (team.member() != 0) return;
    out.offsets[0] = 0;
    for (std::size_t q = 1; q < out.offsets.size(); ++q) out.offsets[q] += out.offsets[q - 1];
    out.indices.resize(out.offsets.back());
    out.sq_dists.resize(out.offsets.back());
  });
  team.phase([&] {
    each_slice_of_mine([&](std::size_t first, const Neighbours& slice) {
      if (order.empty()) {  // the slice's rows are consecutive in out too
        const auto to = static_cast<std::ptrdiff_t>(out.offsets[first]);
        std::copy(slice.indices.begin(), slice.indices.end(), out.indices.begin() + to);
        std::copy(slice.sq_dists.begin(), slice.sq_dists.end(), out.sq_dists.begin() + to);
        return;
      }
      for (std::size_t j = 0; j < slice.n_queries(); ++j) {
        const auto from = static_cast<std::ptrdiff_t>(slice.offsets[j]);
        const auto to = static_cast<std::ptrdiff_t>(out.offsets[query_at(first + j)]);
        const auto count = static_cast<std::ptrdiff_t>(slice.count(j));
        std::copy_n(slice.indices.begin() + from, count, out.indices.begin() + to);
        std::copy_n(slice.sq_dists.begin() + from, count, out.sq_dists.begin() + to);
      }
    });
  });
}

}  // namespace

void SearchIndex::answer_in_slices(const Cloud& queries, Neighbours& out, const SliceAnswer& answer,
                                   bool may_reorder) const {
  const Eigen::Index n = queries.cols();
  const Eigen::Index most = std::max<Eigen::Index>(1, n / kMinQueriesPerThread);
  const int threads = info_.concurrency == Concurrency::queries ? static_cast<int>(std::min<Eigen::Index>(threads_, most)) : 1;
  if (model_size_ == 0) throw InputError(info_.name + ": search before build");
  if (threads == 1) {
    check_queries(queries);
    answer(queries, 0, out);
    return;
  }
  const std::vector<Eigen::Index> starts = slice_starts(n, threads, kMinQueriesPerThread);
  std::vector<Neighbours> rows(starts.size() - 1);
  std::vector<int> answered_by(rows.size());
  std::vector<PointIndex> order;  // empty: the caller's
  out.offsets.resize(static_cast<std::size_t>(n) + 1);
  std::atomic<std::size_t> next{0};
  Team::Shared shared;
  std::atomic<bool> out_of_range{false};
  const std::function<void(int)> work = [&](int member) {
    const Team team(member, shared);
    check_queries_on(team, queries, out_of_range);
    if (may_reorder) slicing_order(queries, team, order);
    team.phase([&] { answer_slices(queries, starts, order, answer, member, next, rows, answered_by); });
    return_rows(team, starts, order, rows, answered_by, out);
  };
  const WorkerPool::ForBatch pool;
  const int helpers = pool.pool().start(threads - 1, work);  // those running, this thread included, are the team
  shared.size.store(helpers + 1, std::memory_order_release);
  work(0);
  pool.pool().finish();
  if (shared.error) std::rethrow_exception(shared.error);
}

void SearchIndex::slicing_order(const Cloud&, const Team&, std::vector<PointIndex>&) const {}

void SearchIndex::knn(const Cloud& queries, int k, Neighbours& out) const {
  check_supported(SearchKind::knn);
  check_k(info_.name, k);
  k = useful_k(k);
  answer_in_slices(queries, out, [&](const Cloud& slice, Eigen::Index, Neighbours& rows) { do_knn(slice, k, rows); });
}

void SearchIndex::radius(const Cloud& queries, double radius_m, Neighbours& out) const {
  check_supported(SearchKind::radius);
  check_distance(info_.name, "radius", radius_m);
  answer_in_slices(queries, out,
                   [&](const Cloud& slice, Eigen::Index, Neighbours& rows) { do_radius(slice, radius_m, rows); });
}

void SearchIndex::ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>& hints,
                                Neighbours& out) const {
  if (hints.size() != static_cast<std::size_t>(queries.cols())) {
    throw InputError(info_.name + ": " + std::to_string(hints.size()) + " hints for " +
                     std::to_string(queries.cols()) + " queries (one per query, kNoHint for none)");
  }
  for (std::size_t q = 0; q < hints.size(); ++q) {
    if (hints[q] != kNoHint && hints[q] >= model_size_) {
      throw InputError(info_.name + ": the hint of query " + std::to_string(q) + " (" + std::to_string(hints[q]) +
                       ") is not a model point (" + std::to_string(model_size_) + " points)");
    }
  }
  if (!info_.uses_hints) {
    ranged(queries, 1, max_dist_m, out);
    return;
  }
  check_supported(SearchKind::ranged);
  check_distance(info_.name, "max_dist", max_dist_m);
  answer_in_slices(queries, out, [&](const Cloud& slice, Eigen::Index first, Neighbours& rows) {
    if (slice.cols() == queries.cols()) return do_ranged_hinted(slice, max_dist_m, hints, rows);
    const auto begin = hints.begin() + first;
    do_ranged_hinted(slice, max_dist_m, std::vector<PointIndex>(begin, begin + slice.cols()), rows);
  }, /*may_reorder=*/false);
}

void SearchIndex::do_ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>&,
                                   Neighbours& out) const {
  do_ranged(queries, 1, max_dist_m, out);
}

void SearchIndex::ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const {
  ranged(queries, k, max_dist_m, out, info_.ranged);
}

void SearchIndex::search(SearchKind kind, const Cloud& queries, int k, double max_dist_m, Neighbours& out) const {
  search(kind, queries, k, max_dist_m, out, info_.ranged);
}

void SearchIndex::search(SearchKind kind, const Cloud& queries, int k, double max_dist_m, Neighbours& out,
                         Strategy strategy) const {
  switch (kind) {
    case SearchKind::knn: knn(queries, k, out); return;
    case SearchKind::radius: radius(queries, max_dist_m, out); return;
    case SearchKind::ranged: ranged(queries, k, max_dist_m, out, strategy); return;
  }
}

void SearchIndex::ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out, Strategy strategy) const {
  check_supported(SearchKind::ranged);
  check_offered(info_, SearchKind::ranged, strategy);
  check_k(info_.name, k);
  check_distance(info_.name, "max_dist", max_dist_m);
  k = useful_k(k);
  answer_in_slices(queries, out, [&](const Cloud& slice, Eigen::Index, Neighbours& rows) {
    switch (strategy) {
      case Strategy::via_knn:
        do_knn(slice, k, rows);
        filter_by_sq_dist(max_dist_m * max_dist_m, rows);
        return;
      case Strategy::via_radius:
        do_radius(slice, max_dist_m, rows);
        sort_and_truncate(static_cast<std::size_t>(k), rows);
        return;
      default:
        do_ranged(slice, k, max_dist_m, rows);
    }
  });
}

void SearchIndex::do_radius(const Cloud&, double, Neighbours&) const {
  throw std::logic_error(info_.name + " declares a radius strategy but does not implement it");
}

void SearchIndex::do_ranged(const Cloud&, int, double, Neighbours&) const {
  throw std::logic_error(info_.name + " declares native ranged search but does not implement it");
}

int ParamReader::get_int(const std::string& name, int fallback, int min, int max) {
  int value = fallback;
  if (const auto it = given_.find(name); it != given_.end()) {
    std::size_t used = 0;
    try {
      value = std::stoi(it->second, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != it->second.size()) {
      throw InputError(adapter_ + ": parameter " + name + " must be an integer (got '" + it->second + "')");
    }
  }
  if (value < min || value > max) {
    throw InputError(adapter_ + ": parameter " + name + " must lie in [" + std::to_string(min) + ", " +
                     std::to_string(max) + "] (got " + std::to_string(value) + ")");
  }
  effective_[name] = std::to_string(value);
  return value;
}

double ParamReader::get_double(const std::string& name, double fallback, double min, double max) {
  double value = fallback;
  if (const auto it = given_.find(name); it != given_.end()) {
    std::size_t used = 0;
    try {
      value = std::stod(it->second, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != it->second.size() || !std::isfinite(value)) {
      throw InputError(adapter_ + ": parameter " + name + " must be a number (got '" + it->second + "')");
    }
  }
  if (value < min || value > max) {
    std::ostringstream msg;
    msg << adapter_ << ": parameter " << name << " must lie in [" << min << ", " << max << "] (got " << value
        << ")";
    throw InputError(msg.str());
  }
  char text[32];  // shortest text that reads back as the same double: reported parameters are lossless
  effective_[name] = std::string(text, std::to_chars(text, text + sizeof text, value).ptr);
  return value;
}

int ParamReader::get_bucket(const std::string& name, int fallback, int min, int max, int sensible_min,
                            int sensible_max) {
  const int value = get_int(name, fallback, min, max);
  bucket_ = AdapterInfo::BucketParam{name, value, sensible_min, sensible_max};
  return value;
}

std::string ParamReader::get_choice(const std::string& name, const std::string& fallback,
                                    const std::vector<std::string>& allowed) {
  std::string value = fallback;
  if (const auto it = given_.find(name); it != given_.end()) value = it->second;
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw InputError(adapter_ + ": parameter " + name + " must be one of " + list + " (got '" + value + "')");
  }
  effective_[name] = value;
  return value;
}

Params ParamReader::finish() const {
  for (const auto& [name, value] : given_) {
    if (effective_.count(name) == 0) {
      std::string known;
      for (const auto& [k, v] : effective_) known += (known.empty() ? "" : ", ") + k;
      throw InputError(adapter_ + ": unknown parameter '" + name + "' (known: " +
                       (known.empty() ? std::string("none") : known) + ")");
    }
  }
  return effective_;
}

void recompute_sq_dists(const Cloud& model, const Cloud& queries, Neighbours& out) {
  for (std::size_t q = 0; q < out.n_queries(); ++q) {
    const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
    for (std::size_t i = out.offsets[q]; i < out.offsets[q + 1]; ++i) {
      out.sq_dists[i] = sq_dist_m2(query, model.col(out.indices[i]).data());
    }
  }
}

void append_rows_in_order(const Neighbours& answered, const std::vector<PointIndex>& order, Neighbours& out) {
  const std::size_t first = out.n_queries(), n = order.size();
  if (answered.n_queries() != n) {
    throw std::logic_error("append_rows_in_order: " + std::to_string(answered.n_queries()) + " rows for an order of " +
                           std::to_string(n) + " queries");
  }
  out.offsets.resize(first + n + 1);
  for (std::size_t s = 0; s < n; ++s) out.offsets[first + order[s] + 1] = answered.count(s);
  for (std::size_t q = first; q < first + n; ++q) out.offsets[q + 1] += out.offsets[q];
  out.indices.resize(out.offsets.back());
  out.sq_dists.resize(out.offsets.back());
  for (std::size_t s = 0; s < n; ++s) {
    const auto from = static_cast<std::ptrdiff_t>(answered.offsets[s]);
    const auto to = static_cast<std::ptrdiff_t>(out.offsets[first + order[s]]);
    const auto count = static_cast<std::ptrdiff_t>(answered.count(s));
    std::copy_n(answered.indices.begin() + from, count, out.indices.begin() + to);
    std::copy_n(answered.sq_dists.begin() + from, count, out.sq_dists.begin() + to);
  }
}

void filter_by_sq_dist(double limit_sq_m2, Neighbours& out) {
  std::size_t write = 0;
  std::size_t begin = 0;
  for (std::size_t q = 0; q < out.n_queries(); ++q) {
    const std::size_t end = out.offsets[q + 1];
    for (std::size_t i = begin; i < end; ++i) {
      if (out.sq_dists[i] <= limit_sq_m2) {
        out.indices[write] = out.indices[i];
        out.sq_dists[write] = out.sq_dists[i];
        ++write;
      }
    }
    begin = end;
    out.offsets[q + 1] = write;
  }
  out.indices.resize(write);
  out.sq_dists.resize(write);
}

void sort_and_truncate(std::size_t k, Neighbours& out) {
  std::vector<std::pair<double, PointIndex>> row;
  std::size_t write = 0;
  std::size_t begin = 0;
  for (std::size_t q = 0; q < out.n_queries(); ++q) {
    const std::size_t end = out.offsets[q + 1];
    row.clear();
    for (std::size_t i = begin; i < end; ++i) row.emplace_back(out.sq_dists[i], out.indices[i]);
    const std::size_t keep = std::min(k, row.size());
    std::partial_sort(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(keep), row.end());
    for (std::size_t i = 0; i < keep; ++i) {
      out.sq_dists[write] = row[i].first;
      out.indices[write] = row[i].second;
      ++write;
    }
    begin = end;
    out.offsets[q + 1] = write;
  }
  out.indices.resize(write);
  out.sq_dists.resize(write);
}

}  // namespace nnb
