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

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
  std::vector<std::uint32_t> counts;   ///< a pass's digit counts, one row per sorting thread
  std::vector<std::uint32_t> starts;   ///< a pass's write positions, one row per sorting thread
  std::vector<std::uint32_t> order;    ///< query indices in Morton order
};

namespace detail {

/// The cell of coordinate x on a grid of 1024 cells from lo with scale cells a metre, clamped to the grid
/// (also for NaN and for spans that overflow, whose scale is 0).
inline std::uint32_t grid_cell(double x, double lo, double scale) {
#if defined(__SSE2__)
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

/// The passes of a radix sort of n keys by the 30 bits above their lower 32. Each pass costs about the same
/// whatever its width while its counts stay in cache: two passes of 15 bits for large batches (nearly half
/// the time of three passes of 10 on 60,000 queries), three of 10 for small ones, whose time is then in
/// clearing and summing 2^15 counts.
struct RadixPasses {
  int width;
  int count;
  explicit RadixPasses(std::size_t n) : width(n >= (std::size_t(1) << 15) ? 15 : 10), count(30 / width) {}
  std::size_t digits() const { return std::size_t(1) << width; }
  int shift(int pass) const { return 32 + pass * width; }
};

/// counts[d] = how many of the keys [first, last) have digit d at shift.
inline void count_digits(const std::uint64_t* keys, std::size_t first, std::size_t last, int shift,
                         const RadixPasses& passes, std::uint32_t* counts) {
  const std::uint64_t mask = passes.digits() - 1;
  std::fill(counts, counts + passes.digits(), 0u);
  for (std::size_t i = first; i < last; ++i) ++counts[(keys[i] >> shift) & mask];
}

/// Where thread `member` of `members` writes its keys of each digit (starts, one row): after every key of
/// a smaller digit and after the same digit's keys of the members before it, so the pass stays stable.
/// counts holds every member's row.
inline void digit_starts(const std::uint32_t* counts, int members, int member, const RadixPasses& passes,
                         std::uint32_t* starts) {
  const std::size_t digits = passes.digits();
  std::uint32_t before = 0;
  for (std::size_t d = 0; d < digits; ++d) {
    std::uint32_t all = 0, earlier = 0;
    for (int m = 0; m < members; ++m) {
      const std::uint32_t c = counts[std::size_t(m) * digits + d];
      all += c;
      if (m < member) earlier += c;
    }
    starts[d] = before + earlier;
    before += all;
  }
}

/// Moves the keys [first, last) of from to their places in to, by their digit at shift.
inline void scatter_digits(const std::uint64_t* from, std::size_t first, std::size_t last, int shift,
                           const RadixPasses& passes, std::uint32_t* starts, std::uint64_t* to) {
  const std::uint64_t mask = passes.digits() - 1;
  for (std::size_t i = first; i < last; ++i) to[starts[(from[i] >> shift) & mask]++] = from[i];
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

/// Sizes out's buffers for a sort of n keys by `members` threads (out.keys is filled by the caller).
inline void size_for_sort(std::size_t n, int members, QueryOrder& out) {
  const std::size_t rows = std::size_t(members) * detail::RadixPasses(n).digits();
  out.keys.resize(n);
  out.scratch.resize(n);
  out.counts.resize(rows);
  out.starts.resize(rows);
}

/// Sorts the n keys of out->keys by their Morton codes (stable: queries in one cell keep their order) on
/// thread `member` of `members`, each sorting its share [first, last). phase(body) runs body, then waits
/// until every member has run its own (a barrier); on one thread it just runs body. Its bodies alone touch
/// *out, so out may be null where a failed phase makes them skipped. The sorted keys are sorted_keys(*out),
/// the same on any number of threads.
template <class Phase>
void sort_morton_keys_shared(std::size_t n, QueryOrder* out, int members, int member, std::size_t first,
                             std::size_t last, Phase&& phase) {
  const detail::RadixPasses passes(n);
  const std::size_t row = std::size_t(member) * passes.digits();
  for (int pass = 0; pass < passes.count; ++pass) {
    const int shift = passes.shift(pass);
    const auto from = [&] { return (pass % 2 == 0 ? out->keys : out->scratch).data(); };
    const auto to = [&] { return (pass % 2 == 0 ? out->scratch : out->keys).data(); };
    phase([&] { detail::count_digits(from(), first, last, shift, passes, out->counts.data() + row); });
    // Every member's counts are in before any reads them, and read before the next pass counts again.
    phase([&] {
      detail::digit_starts(out->counts.data(), members, member, passes, out->starts.data() + row);
      detail::scatter_digits(from(), first, last, shift, passes, out->starts.data() + row, to());
    });
  }
}

/// The keys sorted by sort_morton_keys_shared: out.keys or, after an odd number of passes, out.scratch.
inline const std::vector<std::uint64_t>& sorted_keys(const QueryOrder& out) {
  return detail::RadixPasses(out.keys.size()).count % 2 == 0 ? out.keys : out.scratch;
}

/// Sorts out.keys on this thread alone; the sorted keys are sorted_keys(out).
inline void sort_morton_keys(QueryOrder& out) {
  const std::size_t n = out.keys.size();
  size_for_sort(n, 1, out);
  sort_morton_keys_shared(n, &out, 1, 0, 0, n, [](auto&& body) { body(); });
}

/// The query indices of sorted keys [first, last) into order (a share, as for morton_keys).
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
  indices_of_keys(sorted_keys(out), 0, n, out.order.data());
}

}  // namespace ours
