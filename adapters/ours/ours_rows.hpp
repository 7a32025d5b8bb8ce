#pragma once
// Shared by the ours_kdtree and ours_octree adapters: run a tree over a batch of queries and turn its
// candidates into exact rows. Double trees compute sq_dist exactly as nnb::sq_dist_m2 (same inputs,
// same order, no FMA: nnb_ours compiles with -ffp-contract=off), so their rows are final. Float trees
// return a conservative superset; its distances are recomputed in double, filtered and truncated.
#include "nnb/search_index.hpp"
#include "ours/collector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace nnb::adapters::ours_rows {

/// Fills out with the k nearest model points within limit_sq_m2 (m^2, inclusive) of each query. The tree
/// searches query q within search_limit_of(q) <= limit_sq_m2, which must still hold the answer (a hint's
/// distance does: nothing nearer than the nearest lies beyond it).
template <typename T, class Tree, class Limits>
void ranged(const Tree& tree, const Cloud& model, const Cloud& queries, int k, double limit_sq_m2,
            Limits&& search_limit_of, Neighbours& out) {
  out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(queries.cols()));
  typename Tree::Buffers buffers;
  std::vector<std::pair<double, PointIndex>> row;
  tree.knn_batch_bounded(queries.data(), static_cast<std::size_t>(queries.cols()), k, search_limit_of, buffers,
                 [&](std::size_t q, const std::vector<ours::Neighbour<T>>& best) {
                   if constexpr (std::is_same_v<T, double>) {
                     for (const auto& n : best) out.push(n.index, n.sq_dist);
                   } else {
                     const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
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
                 });
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
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes = info.scalar == "float" ? "float search widened by its rounding bound, refined in double"
                                        : "distances computed as sq_dist_m2, bit-exact";
    return info;
  }

  explicit OursIndex(AdapterInfo info) : SearchIndex(std::move(info)), use_float_(this->info().params.at("scalar") == "float") {}

  std::size_t index_bytes() const override {
    return use_float_ ? float_.node_bytes() + float_.index_bytes() + float_.point_copy_bytes()
                      : double_.node_bytes() + double_.index_bytes() + double_.point_copy_bytes();
  }

 protected:
  /// Calls build(tree, xyz, n) on the tree of the chosen scalar.
  template <class Build>
  void build_tree(const Cloud& model, Build&& build) {
    model_ = &model;
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
    if (use_float_) ours_rows::ranged<float>(float_, *model_, queries, k, limit_sq_m2, same, out);
    else ours_rows::ranged<double>(double_, *model_, queries, k, limit_sq_m2, same, out);
  }

  // The hint's squared distance (computed as sq_dist_m2, as the double tree computes it; a float tree
  // widens any limit by its rounding bound) bounds the search from the start.
  void do_ranged_hinted(const Cloud& queries, double max_dist_m, const std::vector<PointIndex>& hints,
                        Neighbours& out) const override {
    const double limit_sq_m2 = max_dist_m * max_dist_m;
    const auto hinted = [&](std::size_t q) {
      if (hints[q] == kNoHint) return limit_sq_m2;
      const double sq = sq_dist_m2(queries.col(static_cast<Eigen::Index>(q)).data(), model_->col(hints[q]).data());
      return std::min(sq, limit_sq_m2);
    };
    if (use_float_) ours_rows::ranged<float>(float_, *model_, queries, 1, limit_sq_m2, hinted, out);
    else ours_rows::ranged<double>(double_, *model_, queries, 1, limit_sq_m2, hinted, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    if (use_float_) ours_rows::radius<float>(float_, *model_, queries, radius_m, out);
    else ours_rows::radius<double>(double_, *model_, queries, radius_m, out);
  }

 private:
  const Cloud* model_ = nullptr;
  bool use_float_ = false;
  Tree<float> float_;
  Tree<double> double_;
};

}  // namespace nnb::adapters::ours_rows
