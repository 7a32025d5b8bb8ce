#pragma once
// The order a batch of queries is answered in. Consecutive queries that are neighbours in space share
// most of their descent and often their leaf, which the trees' batch searches exploit; a batch in random
// order gets none of that. morton_order() sorts a batch along the Z-order curve of a grid over the
// queries' bounding box (10 bits an axis, an LSD radix sort: linear time), so a tree can answer it in
// that order and return the rows in the caller's: the same answers whatever order the caller gives.
#include "ours/collector.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace ours {

namespace detail {
constexpr std::array<std::uint32_t, 1024> spread_table() {
  std::array<std::uint32_t, 1024> table{};
  for (std::uint32_t v = 0; v < 1024; ++v) {
    for (std::uint32_t bit = 0; bit < 10; ++bit) table[v] |= ((v >> bit) & 1u) << (3 * bit);
  }
  return table;
}
// A table lookup: the shift-and-mask cascade was half of a batch's ordering time.
inline constexpr std::array<std::uint32_t, 1024> kSpread = spread_table();
}  // namespace detail

/// Spreads the low 10 bits of v to every third bit (bit i to bit 3i).
inline std::uint32_t spread_bits_3(std::uint32_t v) { return detail::kSpread[v & 0x3ffu]; }

/// Scratch space for morton_order, kept between batches so a batch allocates nothing.
struct QueryOrder {
  std::vector<std::uint64_t> keys;     ///< (Morton code << 32) | query index, sorted
  std::vector<std::uint64_t> scratch;  ///< the radix sort's other buffer
  std::vector<std::uint32_t> counts;   ///< the radix sort's counts, a table a pass
  std::vector<std::uint32_t> order;    ///< query indices in Morton order
};

/// Sorted runs of Morton keys, each as its [begin, end) pointers.
using KeyRun = std::pair<const std::uint64_t*, const std::uint64_t*>;
using KeyRuns = std::vector<KeyRun>;

namespace detail {

/// The cell of coordinate x on a grid of 1024 cells from lo with scale cells a metre, clamped to the grid
/// (also for NaN and for spans that overflow, whose scale is 0).
inline std::uint32_t grid_cell(double x, double lo, double scale) {
#if defined(OURS_SSE2)
  // Branch-free: maxsd returns its second operand when either is NaN.
  __m128d t = _mm_mul_sd(_mm_sub_sd(_mm_set_sd(x), _mm_set_sd(lo)), _mm_set_sd(scale));
  t = _mm_min_sd(_mm_max_sd(t, _mm_setzero_pd()), _mm_set_sd(1023.0));
  return static_cast<std::uint32_t>(_mm_cvttsd_si32(t));
#else
  const double t = (x - lo) * scale;
  if (!(t > 0.0)) return 0;
  return t >= 1023.0 ? 1023u : static_cast<std::uint32_t>(t);
#endif
}

/// Sorts the n keys at keys by the 30 bits above their lower 32 in three stable passes of 10 bits between
/// keys and scratch; returns where the sorted keys lie (keys or scratch's memory). One read of the keys
/// counts for all three passes, so each pass after it is a single scatter, and the three tables of 1,024
/// counts stay in L1 (two passes of 15 bits, each counting on its own, took 1.02-1.25x as long on 3,000 to
/// 120,000 keys: 32,768 counts a pass spill out of L1).
inline std::uint64_t* radix_sort_codes(std::uint64_t* keys, std::size_t n, std::vector<std::uint64_t>& scratch,
                                       std::vector<std::uint32_t>& counts) {
  constexpr int kWidth = 10;
  constexpr int kPasses = 3;  // 30 code bits
  constexpr std::size_t kBuckets = std::size_t(1) << kWidth;
  constexpr std::uint64_t kMask = kBuckets - 1;
  counts.assign(kPasses * kBuckets, 0u);
  scratch.resize(n);
  std::uint32_t* const count0 = counts.data();
  std::uint32_t* const count1 = count0 + kBuckets;
  std::uint32_t* const count2 = count1 + kBuckets;
  for (const std::uint64_t* key = keys; key != keys + n; ++key) {
    const std::uint64_t code = *key >> 32;
    ++count0[code & kMask];
    ++count1[(code >> kWidth) & kMask];
    ++count2[(code >> 2 * kWidth) & kMask];
  }
  for (std::uint32_t* table : {count0, count1, count2}) {
    std::uint32_t sum = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) sum += std::exchange(table[b], sum);
  }
  std::uint64_t* from = keys;
  std::uint64_t* to = scratch.data();
  for (int pass = 0; pass < kPasses; ++pass) {
    std::uint32_t* const start = count0 + pass * kBuckets;
    const int shift = 32 + pass * kWidth;
    for (const std::uint64_t* key = from; key != from + n; ++key) {
      const std::uint64_t value = *key;  // read once: for all the compiler knows, the store changes it
      to[start[(value >> shift) & kMask]++] = value;
    }
    std::swap(from, to);
  }
  return from;
}

/// The number of keys not above value in sorted runs.
inline std::size_t count_not_above(const KeyRuns& runs, std::uint64_t value) {
  std::size_t count = 0;
  for (const KeyRun& run : runs) {
    count += static_cast<std::size_t>(std::upper_bound(run.first, run.second, value) - run.first);
  }
  return count;
}

/// The key of rank r (from 0, below their total) among sorted runs of distinct keys: a binary search on
/// the value, 64 steps of one binary search a run.
inline std::uint64_t key_of_rank(const KeyRuns& runs, std::size_t r) {
  std::uint64_t lo = 0, hi = ~std::uint64_t(0);
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    if (count_not_above(runs, mid) > r) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return lo;
}

/// Where each run's keys of rank r or more (among all runs' total, distinct keys) begin.
inline std::vector<const std::uint64_t*> cuts_at_rank(const KeyRuns& runs, std::size_t r, std::size_t total) {
  std::vector<const std::uint64_t*> cuts(runs.size());
  const std::uint64_t key = 0 < r && r < total ? key_of_rank(runs, r) : 0;
  for (std::size_t t = 0; t < runs.size(); ++t) {
    cuts[t] = r == 0       ? runs[t].first
              : r >= total ? runs[t].second
                           : std::lower_bound(runs[t].first, runs[t].second, key);
  }
  return cuts;
}

/// Each run cut to its keys of ranks [first, last) among all runs.
inline KeyRuns runs_of_ranks(const KeyRuns& runs, std::size_t first, std::size_t last, std::size_t total) {
  const std::vector<const std::uint64_t*> begins = cuts_at_rank(runs, first, total);
  const std::vector<const std::uint64_t*> ends = cuts_at_rank(runs, last, total);
  KeyRuns parts(runs.size());
  for (std::size_t t = 0; t < runs.size(); ++t) parts[t] = {begins[t], ends[t]};
  return parts;
}

/// Merges two sorted runs' indices into order, branch-free (which run gives the next key is a coin toss).
inline void merge_two_runs(KeyRun a, KeyRun b, std::uint32_t* order) {
  while (a.first != a.second && b.first != b.second) {
    const bool take_b = *b.first < *a.first;
    *order++ = static_cast<std::uint32_t>(take_b ? *b.first : *a.first);
    a.first += !take_b;
    b.first += take_b;
  }
  for (KeyRun rest : {a, b}) {
    for (; rest.first != rest.second; ++rest.first) *order++ = static_cast<std::uint32_t>(*rest.first);
  }
}

}  // namespace detail

/// The grid morton_order sorts on: 1024 cells an axis over a box, one cube for all axes (cells stay
/// cubic). Point clouds are surfaces, so a batch fills a grid's cells as their square, not their cube:
/// a coarser grid for a smaller batch left many queries to a cell, in the caller's order.
struct MortonGrid {
  std::array<double, 3> lo{0, 0, 0};
  double scale = 0.0;  ///< cells a metre; 0 puts every query in one cell
};

/// The grid over the box [lo, hi]. An infinite span (coordinates near the double range's ends) gives
/// scale 0 and one cell; NaNs fall in cell 0.
inline MortonGrid morton_grid(const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  double span_m = 0;
  for (int d = 0; d < 3; ++d) span_m = std::max(span_m, hi[d] - lo[d]);
  return {lo, span_m > 0.0 && span_m < 1e300 ? 1024.0 / span_m : 0.0};
}

/// keys[i] = (Morton code << 32) | i for the queries first to last - 1 (a share of a batch: threads may
/// each fill their own).
inline void morton_keys(const double* xyz, std::size_t first, std::size_t last, const MortonGrid& grid,
                        std::uint64_t* keys) {
  for (std::size_t i = first; i < last; ++i) {
    const double* q = xyz + 3 * i;
    const std::uint64_t code = spread_bits_3(detail::grid_cell(q[0], grid.lo[0], grid.scale)) |
                               spread_bits_3(detail::grid_cell(q[1], grid.lo[1], grid.scale)) << 1 |
                               spread_bits_3(detail::grid_cell(q[2], grid.lo[2], grid.scale)) << 2;
    keys[i] = code << 32 | static_cast<std::uint32_t>(i);
  }
}

/// Sorts the n keys at keys by their Morton codes (stable), with work's scratch and counts; returns where
/// they now lie: keys, or work.scratch's memory (valid until work is used again).
inline const std::uint64_t* sort_morton_keys(std::uint64_t* keys, std::size_t n, QueryOrder& work) {
  return detail::radix_sort_codes(keys, n, work.scratch, work.counts);
}

/// Sorts out.keys by their Morton codes (stable: queries in one cell keep their order).
inline void sort_morton_keys(QueryOrder& out) {
  if (sort_morton_keys(out.keys.data(), out.keys.size(), out) != out.keys.data()) out.keys.swap(out.scratch);
}

/// order[first, last) = the indices (lower 32 bits) of the keys of ranks first to last - 1 among sorted
/// runs of distinct keys: the merged order, each part of which a thread of a team may fill on its own.
inline void merge_key_runs(const KeyRuns& runs, std::size_t first, std::size_t last, std::uint32_t* order) {
  std::size_t total = 0;
  for (const KeyRun& run : runs) total += static_cast<std::size_t>(run.second - run.first);
  KeyRuns parts = detail::runs_of_ranks(runs, first, last, total);
  if (parts.size() == 2) return detail::merge_two_runs(parts[0], parts[1], order + first);
  for (std::size_t i = first; i < last; ++i) {
    std::size_t next = parts.size();
    for (std::size_t t = 0; t < parts.size(); ++t) {
      if (parts[t].first == parts[t].second) continue;
      if (next == parts.size() || *parts[t].first < *parts[next].first) next = t;
    }
    order[i] = static_cast<std::uint32_t>(*parts[next].first++);
  }
}

/// The query indices of sorted keys [first, last) into order.
inline void indices_of_keys(const std::vector<std::uint64_t>& keys, std::size_t first, std::size_t last,
                            std::uint32_t* order) {
  for (std::size_t i = first; i < last; ++i) order[i] = static_cast<std::uint32_t>(keys[i]);
}

/// Fills out.order with the n queries' indices (xyz: x,y,z triples, metres) in Morton order of a
/// 1024^3 grid over their bounding box; queries in one cell keep the caller's order.
inline void morton_order(const double* xyz, std::size_t n, QueryOrder& out) {
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  if (n > 0) bounding_box(xyz, n, lo, hi);
  out.keys.resize(n);
  morton_keys(xyz, 0, n, morton_grid(lo, hi), out.keys.data());
  sort_morton_keys(out);
  out.order.resize(n);
  indices_of_keys(out.keys, 0, n, out.order.data());
}

}  // namespace ours
