#pragma once
// Shared by the ours_kdtree and ours_octree adapters: run a tree over a batch of queries and turn its
// candidates into exact rows. Double trees compute sq_dist exactly as nnb::sq_dist_m2 (same inputs,
// same order, no FMA: nnb_ours compiles with -ffp-contract=off), so their rows are final. Float trees
// return a conservative superset; its distances are recomputed in double, filtered and truncated.
#include "nnb/search_index.hpp"
#include "nnb/team.hpp"
#include "ours/collector.hpp"
#include "ours/neighbour_graph.hpp"
#include "ours/query_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace nnb::adapters::ours_rows {

/// Appends to out the row of one query from a tree's candidates: final for a double tree; for a float
/// tree (a superset) the distances are recomputed in double, filtered by limit_sq_m2 and cut to k.
template <typename T>
void append_row(const std::vector<ours::Neighbour<T>>& best, const double* query, const Cloud& model, int k,
                double limit_sq_m2, std::vector<std::pair<double, PointIndex>>& row, Neighbours& out) {
  if constexpr (std::is_same_v<T, double>) {
    for (const auto& n : best) out.push(n.index, n.sq_dist);
  } else {
    row.clear();
    for (const auto& n : best) {
      const double sq = sq_dist_m2(query, model.col(n.index).data());
      if (sq <= limit_sq_m2) row.emplace_back(sq, n.index);
    }
    const std::size_t keep = std::min(row.size(), static_cast<std::size_t>(k));
    std::partial_sort(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(keep), row.end());
    for (std::size_t i = 0; i < keep; ++i) out.push(row[i].second, row[i].first);
  }
  out.end_query();
}

/// A 1-NN row kept aside until the rows are put in the caller's order; index kNone: nothing within the limit.
struct NearestRow {
  static constexpr PointIndex kNone = static_cast<PointIndex>(-1);
  PointIndex index = kNone;
  double sq_m2 = 0.0;
};

/// The row of one 1-NN query, as append_row would write it with k = 1.
template <typename T>
NearestRow nearest_row(const std::vector<ours::Neighbour<T>>& best, const double* query, const Cloud& model,
                       double limit_sq_m2) {
  NearestRow nearest;
  if constexpr (std::is_same_v<T, double>) {
    if (!best.empty()) nearest = {best.front().index, best.front().sq_dist};
  } else {
    for (const auto& n : best) {
      const double sq = sq_dist_m2(query, model.col(n.index).data());
      if (sq > limit_sq_m2) continue;
      if (nearest.index == NearestRow::kNone || sq < nearest.sq_m2 || (sq == nearest.sq_m2 && n.index < nearest.index))
        nearest = {n.index, sq};
    }
  }
  return nearest;
}

/// Appends the rows of 1-NN answers, in their order.
inline void append_nearest_rows(const std::vector<NearestRow>& rows, Neighbours& out) {
  for (const NearestRow& row : rows) {
    if (row.index != NearestRow::kNone) out.push(row.index, row.sq_m2);
    out.end_query();
  }
}

/// Memory for answering a batch in Morton order, kept by each thread between batches: fresh memory costs
/// a page fault a page on every batch (most of the time of a 60,000-query batch), unless it is huge.
struct MortonScratch {
  using Box = std::pair<std::array<double, 3>, std::array<double, 3>>;
  ours::QueryOrder order;
  std::vector<double> sorted_xyz;  ///< the queries in Morton order
  Neighbours answered;             ///< their rows, in that order
  std::vector<NearestRow> nearest;  ///< for 1-NN: their rows, in the caller's order
  std::vector<Box> share_boxes;    ///< on threads: the box of each member's share
  ours::KeyRuns share_runs;        ///< on threads: each member's share of the keys, sorted

  /// An empty share's box: lo = +inf, hi = -inf, which joins to nothing.
  static Box empty_box() {
    constexpr double inf = std::numeric_limits<double>::infinity();
    return {{inf, inf, inf}, {-inf, -inf, -inf}};
  }

  /// The box of every share.
  Box joined_box() const {
    Box all = empty_box();
    for (const Box& box : share_boxes) {
      for (int d = 0; d < 3; ++d) {
        all.first[d] = std::min(all.first[d], box.first[d]);
        all.second[d] = std::max(all.second[d], box.second[d]);
      }
    }
    return all;
  }

  /// Frees a large batch's memory (a helper thread holds only its share's sort buffer).
  void release_if_large() {
    constexpr std::size_t kLarge = std::size_t(1) << 20;
    if (order.keys.size() > kLarge || order.scratch.size() > kLarge) *this = MortonScratch{};
  }
};

inline MortonScratch& morton_scratch() {
  thread_local MortonScratch scratch;
  return scratch;
}

/// order (sized to the batch) = the queries' Morton order, as ours::morton_order makes it, found by a
/// team: each member finds the box and the keys of its share, sorts those keys in its own MortonScratch
/// and merges its part of the order from every member's sorted keys (the whole batch sorted on member 0
/// kept the others waiting).
inline void morton_order_on_team(const Cloud& queries, const Team& team, std::vector<PointIndex>& order) {
  const auto n = static_cast<std::size_t>(queries.cols());
  team.phase([&] {
    if (team.member() != 0) return;
    MortonScratch& scratch = morton_scratch();
    scratch.share_boxes.resize(static_cast<std::size_t>(team.size()));
    scratch.share_runs.resize(static_cast<std::size_t>(team.size()));
    scratch.order.keys.resize(n);
    team.publish(scratch);
  });
  MortonScratch* scratch = team.scratch<MortonScratch>();  // used in bodies only: null if its phase failed
  const std::pair<std::size_t, std::size_t> mine = team.share(n);
  team.phase([&] {
    MortonScratch::Box& box = scratch->share_boxes[static_cast<std::size_t>(team.member())];
    box = MortonScratch::empty_box();
    if (mine.second > mine.first) {
      ours::bounding_box(queries.data() + 3 * mine.first, mine.second - mine.first, box.first, box.second);
    }
  });
  team.phase([&] {
    const MortonScratch::Box all = scratch->joined_box();  // the same on every member
    ours::morton_keys(queries.data(), mine.first, mine.second, ours::morton_grid(all.first, all.second),
                      scratch->order.keys.data());
    const std::size_t count = mine.second - mine.first;
    const std::uint64_t* sorted =
        ours::sort_morton_keys(scratch->order.keys.data() + mine.first, count, morton_scratch().order);
    scratch->share_runs[static_cast<std::size_t>(team.member())] = {sorted, sorted + count};
  });
  team.phase([&] { ours::merge_key_runs(scratch->share_runs, mine.first, mine.second, order.data()); });
  morton_scratch().release_if_large();  // each member its own; member 0's is the published one
}

/// The order a batch is answered in (the adapters' "order" parameter): "caller" (as given), "morton"
/// (sorted along the Z-order curve, see ours/query_order.hpp) or "auto" (judged from a first slice).
enum class Order { automatic, caller, morton };

inline Order order_named(const std::string& name) {
  return name == "caller" ? Order::caller : name == "morton" ? Order::morton : Order::automatic;
}

/// How many queries of a batch "auto" answers in the caller's order before it judges that order.
constexpr std::size_t kOrderProbe = 256;
/// The fewest queries worth sorting.
constexpr std::size_t kMinMortonBatch = 64;

/// Whether the first kOrderProbe of the n queries at xyz mostly follow each other closely in tree (at
/// least half of them the previous one's leaf or descent, as a scan's points do).
template <class Tree>
bool follows_a_scan(const Tree& tree, const double* xyz, std::size_t n) {
  typename Tree::Buffers buffers;
  const std::size_t probe = std::min(n, kOrderProbe);
  const std::size_t close = tree.knn_batch(xyz, probe, 1, 0.0, buffers, [](std::size_t, const auto&) {});
  return 2 * close >= probe;
}

/// Fills out with the k nearest model points within limit_sq_m2 (m^2, inclusive) of each query. The tree
/// searches query q within search_limit_of(q) <= limit_sq_m2, which must still hold the answer (a hint's
/// distance does: nothing nearer than the nearest lies beyond it). The rows are in the caller's order
/// whatever order the queries are answered in (see Order).
///
/// "auto": the first kOrderProbe queries are answered in the caller's order, and the tree reports how
/// many followed the previous query closely (its leaf, or its descent). If most did (a scan's points,
/// one after the other), the rest follow in the caller's order too; otherwise they are answered in
/// Morton order.
template <typename T, class Tree, class Limits>
void ranged(const Tree& tree, const Cloud& model, const Cloud& queries, int k, double limit_sq_m2,
            Limits&& search_limit_of, Order order_choice, Neighbours& out) {
  const auto n = static_cast<std::size_t>(queries.cols());
  typename Tree::Buffers buffers;
  std::vector<std::pair<double, PointIndex>> row;
  // Searches the count queries at xyz (the i-th is query query_of(i) of the batch), calling emit(i, best);
  // returns how many followed the previous one closely.
  const auto search = [&](const double* xyz, std::size_t count, auto&& query_of, auto&& emit) {
    return tree.knn_batch_bounded(
        xyz, count, k, [&](std::size_t i) { return search_limit_of(query_of(i)); }, buffers, emit);
  };
  // The same, appending each query's row to rows.
  const auto answer = [&](const double* xyz, std::size_t count, auto&& query_of, Neighbours& rows) {
    return search(xyz, count, query_of, [&](std::size_t i, const std::vector<ours::Neighbour<T>>& best) {
      append_row<T>(best, xyz + 3 * i, model, k, limit_sq_m2, row, rows);
    });
  };
  out.reset(n, n);
  const std::size_t probe = order_choice == Order::automatic ? std::min(n, kOrderProbe) : 0;
  const std::size_t close = answer(queries.data(), probe, [](std::size_t i) { return i; }, out);
  const std::size_t rest = n - probe;
  const bool keep = order_choice == Order::caller || (probe > 0 && 2 * close >= probe);
  if (keep || rest < kMinMortonBatch || rest > std::numeric_limits<std::uint32_t>::max()) {
    answer(queries.data() + 3 * probe, rest, [probe](std::size_t i) { return probe + i; }, out);
    return;
  }
  MortonScratch& scratch = morton_scratch();
  const std::vector<std::uint32_t>& order = scratch.order.order;
  ours::morton_order(queries.data() + 3 * probe, rest, scratch.order);
  scratch.sorted_xyz.resize(3 * rest);
  // Coordinate by coordinate: std::copy_n of three doubles became a library memmove call a query.
  for (std::size_t s = 0; s < rest; ++s) {
    const double* from = queries.data() + 3 * (probe + order[s]);
    double* to = scratch.sorted_xyz.data() + 3 * s;
    to[0] = from[0];
    to[1] = from[1];
    to[2] = from[2];
  }
  const auto query_of = [&](std::size_t s) { return probe + order[s]; };
  if (k == 1) {
    // A row of at most one neighbour is stored straight at its query's place, in one pass.
    scratch.nearest.resize(rest);
    search(scratch.sorted_xyz.data(), rest, query_of, [&](std::size_t s, const std::vector<ours::Neighbour<T>>& best) {
      scratch.nearest[order[s]] = nearest_row<T>(best, scratch.sorted_xyz.data() + 3 * s, model, limit_sq_m2);
    });
    append_nearest_rows(scratch.nearest, out);
  } else {
    scratch.answered.reset(rest, rest);
    answer(scratch.sorted_xyz.data(), rest, query_of, scratch.answered);
    append_rows_in_order(scratch.answered, order, out);
  }
  scratch.release_if_large();
}

/// Fills out with every model point within radius_m (inclusive) of each query, in tree order.
template <typename T, class Tree>
void radius(const Tree& tree, const Cloud& model, const Cloud& queries, double radius_m, Neighbours& out) {
  const double limit_sq_m2 = radius_m * radius_m;
  out.reset(static_cast<std::size_t>(queries.cols()));
  typename Tree::Buffers buffers;
  for (Eigen::Index q = 0; q < queries.cols(); ++q) {
    const double* query = queries.col(q).data();
    tree.radius(query, limit_sq_m2, buffers);
    for (const auto& n : buffers.best) {
      if constexpr (std::is_same_v<T, double>) {
        if (n.sq_dist <= limit_sq_m2) out.push(n.index, n.sq_dist);
      } else {
        const double sq = sq_dist_m2(query, model.col(n.index).data());
        if (sq <= limit_sq_m2) out.push(n.index, sq);
      }
    }
    out.end_query();
  }
}

/// What ours_kdtree and ours_octree share: one tree per scalar (the "scalar" parameter picks one), the
/// index bytes, and the searches; each adapter adds its description and how it builds its tree.
template <template <typename> class Tree>
class OursIndex : public SearchIndex {
 public:
  /// Completes an adapter's description with what both share: native searches, the "scalar" parameter
  /// (read last from reader, after the adapter's own) and the notes on exactness.
  static AdapterInfo shared_info(AdapterInfo info, ParamReader& reader) {
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    info.scalar = reader.get_choice("scalar", "double", {"float", "double"});
    reader.get_choice("order", "auto", {"auto", "caller", "morton"});
    reader.get_choice("hints", "bound", {"bound", "graph"});
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.uses_hints = true;
    info.notes = info.scalar == "float" ? "float search widened by its rounding bound, refined in double"
                                        : "distances computed as sq_dist_m2, bit-exact";
    return info;
  }

  explicit OursIndex(AdapterInfo info)
      : SearchIndex(std::move(info)),
        use_float_(this->info().params.at("scalar") == "float"),
        order_(order_named(this->info().params.at("order"))),
        graph_hints_(this->info().params.at("hints") == "graph") {}

  std::size_t index_bytes() const override {
    return use_float_ ? float_.node_bytes() + float_.index_bytes() + float_.point_copy_bytes()
                      : double_.node_bytes() + double_.index_bytes() + double_.point_copy_bytes();
  }

 protected:
  /// Calls build(tree, xyz, n) on the tree of the chosen scalar.
  template <class Build>
  void build_tree(const Cloud& model, Build&& build) {
    model_ = &model;
    graph_ = std::make_unique<LazyGraph>();
    const auto n = static_cast<std::size_t>(model.cols());
    if (use_float_) build(float_, model.data(), n);
    else build(double_, model.data(), n);
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    do_ranged(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const double limit_sq_m2 = max_dist_m * max_dist_m;
    const auto same = [limit_sq_m2](std::size_t) { return limit_sq_m2; };
    if (use_float_) ours_rows::ranged<float>(float_, *model_, queries, k, limit_sq_m2, same, order_, out);
    else ours_rows::ranged<double>(double_, *model_, queries, k, limit_sq_m2, same, order_, out);
  }

  // hints=bound: each query's search is bounded from the start by its hint's squared distance (computed as
  // sq_dist_m2, as the double tree computes it; a float tree widens any limit by its rounding bound).
  // hints=graph: a query whose hint's row in the neighbour graph proves its nearest point
  // (ours/neighbour_graph.hpp) is answered from it, the others as with hints=bound.
  void do_ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>& hints,
                        Neighbours& out) const override {
    const double limit_sq_m2 = max_dist_m * max_dist_m;
    if (!graph_hints_) return search_bounded_by_hints(queries, limit_sq_m2, hints, out);
    const ours::NeighbourGraph& graph = neighbour_graph();
    HintScratch& s = hint_scratch();
    const auto n = static_cast<std::size_t>(queries.cols());
    s.answers.resize(n);
    s.unproven.clear();
    s.unproven_hints.clear();
    for (std::size_t q = 0; q < n; ++q) {
      HintAnswer& a = s.answers[q];
      a.kind = hints[q] == kNoHint ? ours::NeighbourGraph::Answer::unproven
                                   : graph.nearest(queries.col(static_cast<Eigen::Index>(q)).data(), hints[q],
                                                   limit_sq_m2, a.index, a.sq_m2);
      if (a.kind != ours::NeighbourGraph::Answer::unproven) continue;
      s.unproven.push_back(static_cast<PointIndex>(q));
      s.unproven_hints.push_back(hints[q]);
    }
    gather_columns(queries, s.unproven, s.tree_queries);
    search_bounded_by_hints(s.tree_queries, limit_sq_m2, s.unproven_hints, s.tree_rows);
    merge_hinted_rows(s, out);
    s.release_if_large();
  }

  // On threads, the slices are runs of the Morton order unless the batch follows a scan (or order=caller):
  // sorted slice by slice instead, each thread's queries would be spread over the whole cloud.
  void slicing_order(const Cloud& queries, const Team& team, std::vector<PointIndex>& order) const override {
    team.phase([&] {
      if (team.member() == 0 && sorts_on_threads(queries)) order.resize(static_cast<std::size_t>(queries.cols()));
    });
    if (!order.empty()) morton_order_on_team(queries, team, order);
  }

  // Whether a batch on threads is sliced in Morton order (see slicing_order).
  bool sorts_on_threads(const Cloud& queries) const {
    const auto n = static_cast<std::size_t>(queries.cols());
    if (order_ == Order::caller || n > std::numeric_limits<PointIndex>::max()) return false;
    if (order_ == Order::morton) return true;
    return !(use_float_ ? follows_a_scan(float_, queries.data(), n) : follows_a_scan(double_, queries.data(), n));
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    if (use_float_) ours_rows::radius<float>(float_, *model_, queries, radius_m, out);
    else ours_rows::radius<double>(double_, *model_, queries, radius_m, out);
  }

 private:
  struct HintAnswer {
    ours::NeighbourGraph::Answer kind = ours::NeighbourGraph::Answer::unproven;
    PointIndex index = 0;
    double sq_m2 = 0.0;
  };
  /// A thread's memory for hinted batches, kept between them (see MortonScratch).
  struct HintScratch {
    std::vector<HintAnswer> answers;
    std::vector<PointIndex> unproven;  ///< the queries left to the tree, in the caller's order
    std::vector<PointIndex> unproven_hints;
    Cloud tree_queries;
    Neighbours tree_rows;
    void release_if_large() {
      if (answers.size() > (std::size_t(1) << 20)) *this = HintScratch{};
    }
  };
  static HintScratch& hint_scratch() {
    thread_local HintScratch scratch;
    return scratch;
  }

  void search_bounded_by_hints(const Cloud& queries, double limit_sq_m2, const std::vector<PointIndex>& hints,
                               Neighbours& out) const {
    const auto hinted = [&](std::size_t q) {
      if (hints[q] == kNoHint) return limit_sq_m2;
      const double sq = sq_dist_m2(queries.col(static_cast<Eigen::Index>(q)).data(), model_->col(hints[q]).data());
      return std::min(sq, limit_sq_m2);
    };
    if (use_float_) ours_rows::ranged<float>(float_, *model_, queries, 1, limit_sq_m2, hinted, order_, out);
    else ours_rows::ranged<double>(double_, *model_, queries, 1, limit_sq_m2, hinted, order_, out);
  }

  // The rows in the caller's order: each query's proven answer, or its row from the tree.
  static void merge_hinted_rows(const HintScratch& s, Neighbours& out) {
    out.reset(s.answers.size(), s.answers.size());
    std::size_t u = 0;
    for (const HintAnswer& a : s.answers) {
      if (a.kind == ours::NeighbourGraph::Answer::nearest) {
        out.push(a.index, a.sq_m2);
      } else if (a.kind == ours::NeighbourGraph::Answer::unproven) {
        for (std::size_t e = s.tree_rows.offsets[u]; e < s.tree_rows.offsets[u + 1]; ++e) {
          out.push(s.tree_rows.indices[e], s.tree_rows.sq_dists[e]);
        }
        ++u;
      }
      out.end_query();
    }
  }

  /// The model's neighbour graph, made by the first hinted batch after a build (from the model's own
  /// k-NN, on the index's threads), so that searches without hints never pay for it.
  struct LazyGraph {
    std::once_flag made;
    ours::NeighbourGraph graph;
  };
  const ours::NeighbourGraph& neighbour_graph() const {
    std::call_once(graph_->made, [this] {
      Neighbours rows;
      knn(*model_, ours::NeighbourGraph::kNeighboursAsked, rows);
      graph_->graph.reset(model_->data(), static_cast<std::size_t>(model_->cols()));
      for (std::size_t i = 0; i < rows.n_queries(); ++i) {
        graph_->graph.set(static_cast<std::uint32_t>(i), rows.indices.data() + rows.offsets[i],
                          rows.sq_dists.data() + rows.offsets[i], rows.count(i));
      }
    });
    return graph_->graph;
  }

  const Cloud* model_ = nullptr;
  std::unique_ptr<LazyGraph> graph_;
  bool use_float_ = false;
  Order order_ = Order::automatic;
  bool graph_hints_ = false;
  Tree<float> float_;
  Tree<double> double_;
};

}  // namespace nnb::adapters::ours_rows
