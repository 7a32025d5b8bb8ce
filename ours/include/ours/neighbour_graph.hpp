#pragma once
// Each model point's nearest other model points, for Greenspan and Godin's ICP search: once a query is
// believed near a model point m (in ICP, m was its neighbour before a small pose update), its nearest
// model point can often be proven to be m or one of m's few nearest, with no tree at all.
//
// The proof is the triangle inequality. Sort m's neighbours n_0, n_1, ... by their distances
// d_0 <= d_1 <= ... from m. Every model point other than m and n_0 .. n_{L-1} lies at least d_L from m,
// so at least d_L - |q - m| from q, which is more than |q - m| whenever |q - m| < d_L / 2: the nearest
// point to q is then m or one of n_0 .. n_{L-1}. A query scans m and the fewest candidates its distance
// to m allows. The thresholds (d_L / 2)^2 are stored rounded down with a margin far above the rounding of
// any computed distance, so that the distances compared are those the tree compares (computed as
// nnb::sq_dist_m2), and the nearest is the tree's nearest. Ties between candidates are left to the tree,
// so that the index returned is the tree's too.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace ours {

class NeighbourGraph {
 public:
  /// Candidates kept per point besides itself (each costs a distance when a query needs it).
  static constexpr int kCandidates = 11;
  /// Nearest points a row is made from: itself, the candidates and the one that bounds them.
  static constexpr int kNeighboursAsked = kCandidates + 2;

  /// What nearest() found out about a query.
  enum class Answer { nearest, none_within, unproven };

  /// Prepares rows for the n points at xyz (interleaved x, y, z; kept by reference, must stay alive).
  void reset(const double* xyz, std::size_t n) {
    xyz_ = xyz;
    rows_.assign(n, Row{});
  }

  /// Sets point i's row from its count nearest model points, nearest first, with their squared distances
  /// (i itself may be among them). count < kNeighboursAsked means they are the whole model; otherwise every
  /// other model point lies at least as far as the last of them.
  void set(std::uint32_t i, const std::uint32_t* indices, const double* sq_dists_m2, std::size_t count) {
    const bool whole_model = count < static_cast<std::size_t>(kNeighboursAsked);
    std::uint32_t others[kNeighboursAsked];
    double sq_others[kNeighboursAsked];
    std::size_t n_others = 0;
    bool dropped_self = false;
    for (std::size_t j = 0; j < count; ++j) {
      if (indices[j] == i && !dropped_self) {
        dropped_self = true;
        continue;
      }
      others[n_others] = indices[j];
      sq_others[n_others++] = sq_dists_m2[j];
    }
    // Itself missing means as many duplicates as were asked for: the last one stands for it.
    if (!dropped_self && n_others > 0 && !whole_model) --n_others;
    Row& row = rows_[i];
    for (int l = 0; l <= kCandidates; ++l) {
      const auto at = static_cast<std::size_t>(l);
      if (at < n_others) row.reach_sq_m2[l] = reach_bound(sq_others[at]);
      else row.reach_sq_m2[l] = whole_model ? std::numeric_limits<float>::infinity() : 0.0f;
      if (l < kCandidates) row.candidates[l] = at < n_others ? others[at] : i;
    }
  }

  /// The nearest model point to query within limit_sq_m2 (inclusive), when the query lies close enough to
  /// model point hint to prove it from hint's row (index and sq_m2 set); unproven leaves it to a tree.
  Answer nearest(const double* query, std::uint32_t hint, double limit_sq_m2, std::uint32_t& index,
                 double& sq_m2) const {
    double best = sq_dist(query, xyz_ + 3 * static_cast<std::size_t>(hint));
    const Row& row = rows_[hint];
    int scan = 0;
    while (!(best < static_cast<double>(row.reach_sq_m2[scan]))) {
      if (++scan > kCandidates) return Answer::unproven;
    }
    std::uint32_t best_index = hint;
    bool tie = false;
    for (int l = 0; l < scan; ++l) {
      const std::uint32_t c = row.candidates[l];
      const double sq = sq_dist(query, xyz_ + 3 * static_cast<std::size_t>(c));
      tie = sq == best || (tie && sq > best);
      if (sq < best) {
        best = sq;
        best_index = c;
      }
    }
    if (tie) return Answer::unproven;
    index = best_index;
    sq_m2 = best;
    return best <= limit_sq_m2 ? Answer::nearest : Answer::none_within;
  }

  /// Bytes the rows hold.
  std::size_t bytes() const { return rows_.size() * sizeof(Row); }
  bool empty() const { return rows_.empty(); }

 private:
  struct Row {
    /// reach_sq_m2[L]: a query nearer than this (squared) to the point has its nearest among the point
    /// and candidates[0 .. L-1].
    float reach_sq_m2[kCandidates + 1];
    std::uint32_t candidates[kCandidates];
  };

  // As nnb::sq_dist_m2 (the same operations in the same order; built without FMA contraction).
  static double sq_dist(const double* a, const double* b) {
    const double dx = a[0] - b[0];
    const double dy = a[1] - b[1];
    const double dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
  }

  // (d / 2)^2 for a neighbour at squared distance sq_m2, shrunk by 2^-20 (computed distances are good to
  // about 2^-50) and rounded down to a float (the largest float beyond its range; 0, proving nothing, for NaN).
  static float reach_bound(double sq_m2) {
    const double reach = 0.25 * sq_m2 * (1.0 - std::ldexp(1.0, -20));
    if (std::isnan(reach)) return 0.0f;
    if (reach >= static_cast<double>(std::numeric_limits<float>::max())) return std::numeric_limits<float>::max();
    float f = static_cast<float>(reach);
    if (static_cast<double>(f) > reach) f = std::nextafter(f, 0.0f);
    return f;
  }

  const double* xyz_ = nullptr;
  std::vector<Row> rows_;
};

}  // namespace ours
