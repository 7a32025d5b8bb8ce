#pragma once
// The one search API every library adapter and our own structures implement.
//
// Glossary: ranged search = k nearest within max_dist = nanoflann rknnSearch = Open3D SearchHybrid
// = libnabo knn(..., maxRadius). k-NN = ranged with an infinite limit. Radius search = every point
// within a radius. A point at exactly the limit counts (inclusive) in every query kind and adapter.
#include "nnb/cloud.hpp"
#include "nnb/neighbours.hpp"
#include "nnb/team.hpp"

#include <atomic>
#include <cstddef>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace nnb {

enum class SearchKind { knn, radius, ranged };

/// A query without a hint (ranged_hinted).
inline constexpr PointIndex kNoHint = static_cast<PointIndex>(-1);

/// How an adapter answers one query kind: this is what the paper compares, so it is data.
enum class Strategy {
  native,      ///< the library answers this query itself
  native_unpruned,  ///< the library's own ranged call, but it visits the whole ball (or runs k-NN and cuts)
  via_knn,     ///< k-NN search, then drop what lies beyond the limit (ranged)
  via_radius,  ///< radius search, then keep the k nearest (ranged)
  via_box,     ///< box intersection, then an exact distance filter (radius on R-trees)
  unsupported, ///< not answered at all (only approximate adapters may say so); calls throw InputError
};

const char* to_string(SearchKind kind);
const char* to_string(Strategy strategy);
/// Parses "knn", "radius" or "ranged"; throws InputError otherwise.
SearchKind parse_search_kind(const std::string& text);
/// Parses a strategy's name as to_string writes it ("via_knn"...); throws InputError otherwise.
Strategy parse_strategy(const std::string& text);

/// Whether one built index may answer queries from several threads at once (SearchIndex::set_threads).
enum class Concurrency {
  single,   ///< queries share mutable state (library globals, caches, an interpreter lock): one thread
  queries,  ///< const queries are safe side by side: the API splits a batch over the threads
  library,  ///< the library parallelises a batch itself: the adapter hands it threads()
};

const char* to_string(Concurrency concurrency);

/// Adapter parameters by name (e.g. "bucket_size" -> "10"), as given by a user or reported back.
using Params = std::map<std::string, std::string>;

/// What an adapter is: the columns of the paper's Table 1, and more.
struct AdapterInfo {
  std::string name;       ///< registry name, e.g. "flann_kdtree"
  std::string library;    ///< e.g. "FLANN"
  std::string version;    ///< the library's version, read from its headers
  std::string structure;  ///< e.g. "k-d tree", "octree", "R*-tree"
  std::string scalar;     ///< precision the library computes in: "float" or "double"
  Strategy knn = Strategy::native;
  Strategy radius = Strategy::native;
  Strategy ranged = Strategy::via_knn;
  bool exact = true;      ///< false for approximate searches, which are never cross-checked as exact
  Params params;          ///< effective parameters, defaults included (reals as shortest round-trip text)
  /// The parameter that sets how many points a leaf or bucket holds (the x axis of the paper's Figure 2),
  /// with its effective value and the range worth sweeping; absent when the library fixes it.
  struct BucketParam {
    std::string name;
    int value = 0;
    int sensible_min = 0;
    int sensible_max = 0;
  };
  std::optional<BucketParam> bucket;
  /// Whether ranged_hinted() uses its hints to bound the search (else it answers as ranged() does).
  bool uses_hints = false;
  /// How the adapter may use more than one thread; declared, and checked by the cross-check's threaded runs.
  Concurrency concurrency = Concurrency::single;
  /// Whether build() uses threads() too (else builds run on one thread).
  bool builds_on_threads = false;
  std::string notes;      ///< workarounds the adapter applies, in one line

  /// The default strategy for a kind: the library's own when it has one.
  Strategy strategy(SearchKind kind) const;
  /// Whether this adapter can answer a kind with the strategy: its default, or for ranged search an
  /// emulation by k-NN, or by radius search when the library has one.
  bool offers(SearchKind kind, Strategy strategy) const;
  /// Every strategy offered for a kind, the default first.
  std::vector<Strategy> strategies(SearchKind kind) const;
};

/// Throws InputError, naming what the adapter offers, unless info.offers(kind, strategy).
void check_offered(const AdapterInfo& info, SearchKind kind, Strategy strategy);

/// A spatial index over one model cloud, answering whole query sets at a time.
///
/// Public calls validate their input and throw InputError with a one-line message; declared
/// emulations (ranged via k-NN or via radius) are carried out here, once for every adapter.
class SearchIndex {
 public:
  explicit SearchIndex(AdapterInfo info) : info_(std::move(info)) {}
  virtual ~SearchIndex() = default;
  SearchIndex(const SearchIndex&) = delete;
  SearchIndex& operator=(const SearchIndex&) = delete;

  const AdapterInfo& info() const { return info_; }

  /// Builds the index over model (copied or referenced as the library needs; keep it alive).
  void build(const Cloud& model);
  /// The k nearest points of each query (fewer when the model is smaller), nearest first.
  void knn(const Cloud& queries, int k, Neighbours& out) const;
  /// Every point within radius_m (metres, inclusive) of each query, in the library's order.
  void radius(const Cloud& queries, double radius_m, Neighbours& out) const;
  /// The k nearest points within max_dist_m (metres, inclusive) of each query, nearest first, answered
  /// with the default strategy or with one of info().strategies(SearchKind::ranged).
  void ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const;
  void ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out, Strategy strategy) const;
  /// The search of one kind: knn with k, radius with max_dist_m as its radius, or ranged with both and
  /// strategy; what a kind does not take is ignored.
  void search(SearchKind kind, const Cloud& queries, int k, double max_dist_m, Neighbours& out) const;
  void search(SearchKind kind, const Cloud& queries, int k, double max_dist_m, Neighbours& out,
              Strategy strategy) const;

  /// Ranged 1-NN with a hint per query: hints[q] is a model point believed near query q (ICP: its
  /// neighbour in the previous iteration), or kNoHint. The answers are exactly those of
  /// ranged(queries, 1, max_dist_m, out); an adapter that uses hints starts from the hint's distance as
  /// its bound (Greenspan and Godin's ICP search), the others ignore them.
  void ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>& hints,
                     Neighbours& out) const;

  /// Threads a batch may use (1 to kMaxThreads, default 1): Concurrency::queries adapters answer a batch on
  /// that many threads, in runs of consecutive queries taken in turn (at least kMinQueriesPerThread queries
  /// each, but the last), and return the rows in the caller's order; Concurrency::library adapters hand the number to their library;
  /// Concurrency::single adapters stay on one thread. Throws InputError outside [1, kMaxThreads].
  void set_threads(int threads);
  /// The threads asked for.
  int threads() const { return threads_; }
  /// The threads a large batch actually runs on: threads() unless the adapter is Concurrency::single.
  int threads_used() const { return info_.concurrency == Concurrency::single ? 1 : threads_; }
  /// The threads a build runs on: threads() when info().builds_on_threads, else 1.
  int build_threads_used() const { return info_.builds_on_threads ? threads_ : 1; }
  static constexpr int kMaxThreads = 1024;
  static constexpr Eigen::Index kMinQueriesPerThread = 256;

  /// Bytes the index holds beyond the model points themselves (nodes, buckets, copies).
  virtual std::size_t index_bytes() const = 0;
  /// Number of points in the model the index was built on (0 before build).
  std::size_t model_size() const { return model_size_; }

 protected:
  AdapterInfo& mutable_info() { return info_; }
  virtual void do_build(const Cloud& model) = 0;
  virtual void do_knn(const Cloud& queries, int k, Neighbours& out) const = 0;
  /// Called when info().radius is native or via_box.
  virtual void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const;
  /// Called for the ranged strategies native and native_unpruned.
  virtual void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const;
  /// Called by ranged_hinted when info().uses_hints; hints are checked (one per query, each in range).
  virtual void do_ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>& hints,
                                Neighbours& out) const;
  /// The order a batch split over threads is sliced in: fills order with a permutation of its query
  /// indices (each slice is then a run of it, so that a thread gets neighbouring queries), or leaves it
  /// empty for the caller's order. The rows come back in the caller's order either way. Every member of
  /// the batch's team calls it: order is shared, written in team phases (each member running the same
  /// phases). Default: no phase, the caller's order.
  virtual void slicing_order(const Cloud& queries, const Team& team, std::vector<PointIndex>& order) const;

 private:
  /// Throws InputError naming the first query point that is not finite, else the first out of range.
  void check_queries(const Cloud& queries) const;
  /// The same, each member of the team checking its share.
  void check_queries_on(const Team& team, const Cloud& queries, std::atomic<bool>& out_of_range) const;
  int useful_k(int k) const;
  void check_supported(SearchKind kind) const;
  /// Answers a batch with answer(slice, first query of the slice, rows), split over threads_used()
  /// threads when the adapter is Concurrency::queries (one team: see nnb/team.hpp), and joins the rows in
  /// query order.
  using SliceAnswer = std::function<void(const Cloud& slice, Eigen::Index first, Neighbours& rows)>;
  /// With may_reorder, the slices are runs of slicing_order(queries) (first is then a position in it).
  void answer_in_slices(const Cloud& queries, Neighbours& out, const SliceAnswer& answer,
                        bool may_reorder = true) const;
  AdapterInfo info_;
  std::size_t model_size_ = 0;
  int threads_ = 1;
};

/// Reads typed parameters for an adapter and rejects names it does not know.
class ParamReader {
 public:
  ParamReader(std::string adapter, Params given) : adapter_(std::move(adapter)), given_(std::move(given)) {}
  /// Integer parameter in [min, max], default when absent; records the effective value.
  int get_int(const std::string& name, int fallback, int min, int max);
  /// Real parameter in [min, max], default when absent; records the effective value.
  double get_double(const std::string& name, double fallback, double min, double max);
  /// The adapter's bucket parameter: an integer in [min, max] like get_int, declared with the range worth
  /// sweeping so that drivers need not guess it from names.
  int get_bucket(const std::string& name, int fallback, int min, int max, int sensible_min, int sensible_max);
  /// The bucket parameter read by get_bucket, if any.
  std::optional<AdapterInfo::BucketParam> bucket() const { return bucket_; }
  /// One of the allowed words, default when absent; records the effective value.
  std::string get_choice(const std::string& name, const std::string& fallback,
                         const std::vector<std::string>& allowed);
  /// Throws InputError if a given parameter was never read; returns the effective parameters.
  Params finish() const;

 private:
  std::string adapter_;
  Params given_;
  Params effective_;
  std::optional<AdapterInfo::BucketParam> bucket_;
};

/// Recomputes every squared distance of out in double precision from the model and queries:
/// float libraries use it so that every adapter reports the same exact distances.
void recompute_sq_dists(const Cloud& model, const Cloud& queries, Neighbours& out);
/// Keeps, per query, the entries with sq_dist <= limit_sq_m2 (keeps their order).
void filter_by_sq_dist(double limit_sq_m2, Neighbours& out);
/// Appends rows answered in another order: row s of answered belongs to the order[s]-th query after
/// those out already holds; they are appended in query order.
void append_rows_in_order(const Neighbours& answered, const std::vector<PointIndex>& order, Neighbours& out);
/// Sorts each query's entries by (sq_dist, index) and keeps at most k of them.
void sort_and_truncate(std::size_t k, Neighbours& out);

}  // namespace nnb
