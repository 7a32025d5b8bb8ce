#pragma once
// A compact k-d tree after libnabo (Elseberg et al. 2012, section 3.2): a vector of small nodes in
// pre-order (the left child is the next node), sliding-midpoint splits, buckets of points copied in
// tree order, and the search of Algorithm 3 (per-dimension offsets to the cell, their squared norm
// updated incrementally).
//
// Node layout: 8 bytes for both scalars, as libnabo's compact nodes.
//   word = (right child index << 2) | cut dimension       for a split node (dimension 0..2)
//   word = (bucket size << 2) | 3                          for a leaf
//   cut  = the split plane as a float relative to origin() (split), or the first bucket entry (leaf)
// The plane IS that float: a double tree compares a coordinate with origin + double(cut), computed the
// same way when building and searching, so any float is a valid plane and the double search stays
// bit-exact. Sliding midpoint picks the float nearest the midpoint that leaves points on both sides; a
// cell whose points no float separates (a tiny extent far from the origin) stays a leaf.
//
// Search: Algorithm 3 with an explicit stack of pending far cells. With random queries the descent
// from the root is a chain of dependent loads and unpredictable branches; knn_batch() therefore runs
// the first descents of kBatch queries interleaved and branch-free, so that their chains overlap.
// Queries in scan order (a laser scan's points, one after the other) mostly fall in the previous
// query's leaf: knn_batch() then starts each search from the previous query's descent instead.
#include "ours/collector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <exception>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace ours {

/// A cell the k-d tree search has still to visit: its node, squared distance (m^2) and per-axis offsets.
template <typename T>
struct PendingCell {
  std::array<T, 3> offsets;
  T sq_dist;
  std::uint32_t node;
};

/// One split node on the k-d tree's first descent of a query, kept for the next query.
template <typename T>
struct DescentStep {
  T plane;             ///< the split plane (T, tree coordinates)
  std::uint32_t node;  ///< the split node
  std::uint32_t far;   ///< its child the query did not descend into
  std::uint32_t dim;   ///< the split axis
  bool right;          ///< whether the query went to the right child (coordinate > plane)
};

/// A cell of the tree: lo < p <= hi on each axis (T, tree coordinates).
template <typename T>
struct CellBox {
  std::array<T, 3> lo, hi;
};

/// The k-d tree's per-caller buffers: the answer, plus its explicit stack and its last first descent.
template <typename T>
struct KdTreeBuffers : SearchBuffers<T> {
  std::vector<PendingCell<T>> pending;  ///< the explicit stack (one entry per level at most)
  std::vector<DescentStep<T>> path;     ///< the last first descent (one entry per level)
  std::vector<CellBox<T>> cells;        ///< cells[l]: the cell of that descent's node at level l
};

template <typename T>
class KdTree {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "KdTree<float> or KdTree<double>");

 public:
  /// What a caller keeps between queries (one per thread).
  using Buffers = KdTreeBuffers<T>;

  struct Node {
    std::uint32_t word;
    union {
      float cut;
      std::uint32_t bucket;
    };
    bool is_leaf() const { return (word & 3u) == 3u; }
    unsigned dim() const { return word & 3u; }
    std::uint32_t right_or_size() const { return word >> 2; }
  };
  static_assert(sizeof(Node) == 8, "compact node");

  /// Builds over n points given as x,y,z triples (metres, double). Cut planes are stored relative to
  /// the centre of the bounding box, and float trees store their coordinates relative to it too, so
  /// that large offsets cost no precision.
  /// With threads > 1, the copy of the points and the subtrees below the top splits are built on up to
  /// that many threads; the tree is the same whatever the number.
  void build(const double* xyz, std::size_t n, int bucket_size, int threads = 1) {
    if (bucket_size < 1) throw std::invalid_argument("ours::KdTree: bucket_size must be >= 1");
    if (threads < 1) throw std::invalid_argument("ours::KdTree: threads must be >= 1");
    if (n >= (std::size_t(1) << 30)) throw std::invalid_argument("ours::KdTree: too many points");
    nodes_.clear();
    points_.clear();
    indices_.clear();
    max_depth_ = 0;
    n_ = n;
    bucket_size_ = static_cast<std::uint32_t>(bucket_size);
    origin_ = {0, 0, 0};
    if (n == 0) return;
    std::array<double, 3> lo{}, hi{};
    bounding_box(xyz, n, lo, hi);
    for (int d = 0; d < 3; ++d) origin_[d] = 0.5 * (lo[d] + hi[d]);
    // The copies in T (what the tree compares is exactly what it stores), three arrays of coordinates and
    // the model indices, are what the splits move: the tree is built in place, in its final order.
    points_.resize(3 * n);
    indices_.resize(n);
    on_threads(threads, n, [&](std::size_t first, std::size_t last) {
      for (std::size_t i = first; i < last; ++i) {
        for (int d = 0; d < 3; ++d) points_[d * n + i] = T(xyz[3 * i + d] - point_shift(d));
        indices_[i] = static_cast<std::uint32_t>(i);
      }
    });
    std::array<T, 3> cell_lo, cell_hi;
    for (int d = 0; d < 3; ++d) extent(unsigned(d), 0, static_cast<std::uint32_t>(n), cell_lo[d], cell_hi[d]);
    Subtree tree;
    tree.nodes.reserve(2 * (n / bucket_size_ + 1));
    build_node(tree, 0, static_cast<std::uint32_t>(n), cell_lo, cell_hi, 0, threads);
    nodes_ = std::move(tree.nodes);
    nodes_.shrink_to_fit();
    max_depth_ = tree.max_depth;
    shrink_ = bound_shrink<T>(static_cast<int>(max_depth_));
  }

  /// Returns the split plane of a cut stored as `cut` on axis dim, in the tree's coordinates (T).
  T plane(unsigned dim, float cut) const {
    if constexpr (std::is_same_v<T, float>) return cut;
    else return origin_[dim] + double(cut);
  }

  /// Queries descended together: their dependent node loads overlap instead of waiting on each other.
  static constexpr std::size_t kBatch = 8;

  /// Returns the k nearest points within sq(max distance) limit_sq_m2 (m^2; infinity for plain k-NN),
  /// into buffers.best, nearest first. Float trees return a superset (see collector.hpp).
  void knn(const double* query, int k, double limit_sq_m2, Buffers& buffers) const {
    knn_batch(query, 1, k, limit_sq_m2, buffers, [](std::size_t, const std::vector<Neighbour<T>>&) {});
  }

  /// For each of n queries (x,y,z triples, metres) calls emit(i, buffers.best) with the k nearest
  /// points within limit_sq_m2 (m^2) of query i, nearest first (float: a superset).
  ///
  /// Two ways to the first leaf, chosen batch by batch from how the last kBatch queries fell; both are
  /// exact and give the same answers. Queries in random order descend from the root kBatch at a time,
  /// interleaved. Queries in scan order (most of them in the previous query's leaf) reuse the previous
  /// query's descent instead: the shared part of the path costs no node loads, and a query inside the
  /// previous leaf's cell scans that leaf at once and stops there when its ball lies inside the cell.
  /// Returns how many queries took the second way.
  template <class Emit>
  std::size_t knn_batch(const double* xyz, std::size_t n, int k, double limit_sq_m2, Buffers& buffers,
                        Emit&& emit) const {
    return knn_batch_bounded(xyz, n, k, [limit_sq_m2](std::size_t) { return limit_sq_m2; }, buffers, emit);
  }

  /// knn_batch with a limit per query: limit_sq_m2_of(i) (m^2) for query i.
  template <class Limits, class Emit>
  std::size_t knn_batch_bounded(const double* xyz, std::size_t n, int k, Limits&& limit_sq_m2_of, Buffers& buffers,
                                Emit&& emit) const {
    if (n_ == 0 || k < 1) {
      buffers.best.clear();
      for (std::size_t i = 0; i < n; ++i) emit(i, buffers.best);
      return 0;
    }
    const std::size_t stride = max_depth_ + 2;
    if (buffers.pending.size() < kBatch * stride) buffers.pending.resize(kBatch * stride);
    if (buffers.path.size() < stride) buffers.path.resize(stride);
    if (buffers.cells.size() < stride) buffers.cells.resize(stride);
    std::size_t reused = 0;
    LastDescent last;
    bool in_order = false;
    for (std::size_t first = 0; first < n; first += kBatch) {
      const std::size_t m = std::min(kBatch, n - first);
      std::size_t same_leaf = 0;
      if (in_order) {
        reused += m;
        for (std::size_t j = 0; j < m; ++j) {
          const Query q = make_query(xyz + 3 * (first + j));
          collect_knn(k, limit_sq_m2_of(first + j), q.error, buffers, [&](auto& collect) {
            same_leaf += search_after_last(q, collect, buffers, last) ? 1 : 0;
          });
          emit(first + j, buffers.best);
        }
      } else {
        Descents batch;
        for (std::size_t j = 0; j < m; ++j) {
          batch.q[j] = make_query(xyz + 3 * (first + j));
          batch.limit[j] = search_limit(limit_sq_m2_of(first + j), batch.q[j].error);
          batch.top[j] = buffers.pending.data() + j * stride;
        }
        descend(batch, m);
        for (std::size_t j = 0; j < m; ++j) {
          same_leaf += batch.leaf[j] == (j > 0 ? batch.leaf[j - 1] : last.leaf) ? 1 : 0;
          PendingCell<T>* const bottom = buffers.pending.data() + j * stride;
          collect_knn(k, limit_sq_m2_of(first + j), batch.q[j].error, buffers, [&](auto& collect) {
            search_from(batch.q[j], collect, batch.leaf[j], bottom, batch.top[j]);
          });
          emit(first + j, buffers.best);
        }
        last.leaf = batch.leaf[m - 1];
        last.valid = false;  // no path recorded: the next in-order query descends from the root
      }
      in_order = 2 * same_leaf >= m;
    }
    return reused;
  }

  /// Returns every point within sq(radius) limit_sq_m2 (m^2) in buffers.best, in tree order
  /// (float trees: a superset, see collector.hpp).
  void radius(const double* query, double limit_sq_m2, Buffers& buffers) const {
    buffers.best.clear();
    if (n_ == 0) return;
    const std::size_t stride = max_depth_ + 2;
    if (buffers.pending.size() < stride) buffers.pending.resize(stride);
    Descents one;
    one.q[0] = make_query(query);
    one.limit[0] = search_limit(limit_sq_m2, one.q[0].error);
    one.top[0] = buffers.pending.data();
    descend(one, 1);
    RadiusCollector<T> all(buffers, one.limit[0]);
    search_from(one.q[0], all, one.leaf[0], buffers.pending.data(), one.top[0]);
  }

  /// Returns the nodes, pre-order.
  const std::vector<Node>& nodes() const { return nodes_; }
  /// Returns the model indices of the bucket entries, in tree order.
  const std::vector<std::uint32_t, DefaultInit<std::uint32_t>>& indices() const { return indices_; }
  /// Returns coordinate d of bucket entry i (T; float: relative to origin(), double: as given). The
  /// copies are kept in tree order as three arrays (all x, all y, all z), for vectorised bucket scans.
  T coord(std::size_t i, int d) const { return points_[std::size_t(d) * n_ + i]; }
  /// Returns the origin (metres): the centre of the bounding box; cuts (and float coordinates) are
  /// stored relative to it.
  const std::array<double, 3>& origin() const { return origin_; }
  /// Returns bytes of the nodes.
  std::size_t node_bytes() const { return nodes_.size() * sizeof(Node); }
  /// Returns bytes of the bucket index array.
  std::size_t index_bytes() const { return indices_.size() * sizeof(std::uint32_t); }
  /// Returns bytes of the point copies kept in tree order.
  std::size_t point_copy_bytes() const { return points_.size() * sizeof(T); }

 private:
  struct Query {
    std::array<T, 3> p;
    ErrorModel<T> error;
  };

  Query make_query(const double* query) const {
    Query q;
    double m = 0;
    for (int d = 0; d < 3; ++d) {
      const double rel = query[d] - origin_[d];
      q.p[d] = T(query[d] - point_shift(d));
      m = std::max(m, std::abs(rel));
    }
    // Beyond float range the error model fails anyway; saturate instead of overflowing.
    q.error.abs_m2 = T(std::min(m * m, 1e30));
    return q;
  }

  // What stored coordinates are relative to on axis d: the origin for float, nothing for double.
  double point_shift(int d) const { return std::is_same_v<T, float> ? origin_[d] : 0.0; }

  // The float cut whose plane lies in [pmin, pmax]: the one nearest c, else (rounding moved it out)
  // the lowest at or above pmin, or the highest at or below pmax; false when no float plane fits.
  bool choose_cut(unsigned dim, T c, T pmin, T pmax, float& cut) const {
    cut = std::is_same_v<T, float> ? float(c) : float(double(c) - origin_[dim]);
    if (std::isfinite(cut) && plane(dim, cut) >= pmin && plane(dim, cut) <= pmax) return true;
    const bool below = !(std::isfinite(cut) && plane(dim, cut) > pmax);
    // plane() never decreases along the floats in order: binary search on their ordered bit patterns.
    std::int64_t lo = float_order(-std::numeric_limits<float>::max());
    std::int64_t hi = float_order(std::numeric_limits<float>::max());
    while (lo < hi) {
      const std::int64_t mid = below ? lo + (hi - lo) / 2 : hi - (hi - lo) / 2;
      const T at = plane(dim, ordered_float(mid));
      if (below) {
        if (at >= pmin) hi = mid;
        else lo = mid + 1;
      } else {
        if (at <= pmax) lo = mid;
        else hi = mid - 1;
      }
    }
    cut = ordered_float(lo);
    return plane(dim, cut) >= pmin && plane(dim, cut) <= pmax;
  }

  // Floats as integers in their numeric order (-0 and +0 both map to 0), and back.
  static std::int64_t float_order(float f) {
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    const std::int64_t magnitude = bits & 0x7fffffffu;
    return (bits >> 31) ? -magnitude : magnitude;
  }
  static float ordered_float(std::int64_t key) {
    const std::uint32_t bits = key < 0 ? (static_cast<std::uint32_t>(-key) | 0x80000000u) : static_cast<std::uint32_t>(key);
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
  }

  // The smallest and largest coordinate on axis dim of the points in [begin, end).
  // Several running minima and maxima, so that they are not one chain of dependent instructions; the
  // min(c, m) operand order keeps the running value on ties, as std::min does.
  void extent(unsigned dim, std::uint32_t begin, std::uint32_t end, T& min, T& max) const {
    const T* c = points_.data() + dim * n_;
    min = max = c[begin];
    std::uint32_t i = begin + 1;
#if defined(OURS_SSE2)
    if constexpr (std::is_same_v<T, double>) {
      if (end - i >= 8) {
        __m128d lo[4], hi[4];
        for (int j = 0; j < 4; ++j) lo[j] = hi[j] = _mm_set1_pd(min);
        for (; i + 8 <= end; i += 8) {
          for (int j = 0; j < 4; ++j) {
            const __m128d v = _mm_loadu_pd(c + i + 2 * j);
            lo[j] = _mm_min_pd(v, lo[j]);
            hi[j] = _mm_max_pd(v, hi[j]);
          }
        }
        alignas(16) double lanes[2][8];
        for (int j = 0; j < 4; ++j) {
          _mm_store_pd(lanes[0] + 2 * j, lo[j]);
          _mm_store_pd(lanes[1] + 2 * j, hi[j]);
        }
        for (int j = 0; j < 8; ++j) {
          min = std::min(min, lanes[0][j]);
          max = std::max(max, lanes[1][j]);
        }
      }
    }
#endif
    for (; i < end; ++i) {
      min = std::min(min, c[i]);
      max = std::max(max, c[i]);
    }
  }

  // Whether a point of [begin, end) lies on split_at on axis dim.
  bool any_on_plane(unsigned dim, std::uint32_t begin, std::uint32_t end, T split_at) const {
    const T* c = points_.data() + dim * n_;
    std::uint32_t i = begin;
#if defined(OURS_SSE2)
    if constexpr (std::is_same_v<T, double>) {
      const __m128d s = _mm_set1_pd(split_at);
      for (; i + 8 <= end; i += 8) {
        const __m128d a = _mm_or_pd(_mm_cmpeq_pd(_mm_loadu_pd(c + i), s), _mm_cmpeq_pd(_mm_loadu_pd(c + i + 2), s));
        const __m128d b = _mm_or_pd(_mm_cmpeq_pd(_mm_loadu_pd(c + i + 4), s), _mm_cmpeq_pd(_mm_loadu_pd(c + i + 6), s));
        if (_mm_movemask_pd(_mm_or_pd(a, b)) != 0) return true;
      }
    }
#endif
    for (; i < end; ++i) {
      if (c[i] == split_at) return true;
    }
    return false;
  }

  // Swaps the points at a and b (coordinates and model index).
  void swap_points(std::uint32_t a, std::uint32_t b) {
    T* x = points_.data();
    for (std::size_t d = 0; d < 3; ++d) std::swap(x[d * n_ + a], x[d * n_ + b]);
    std::swap(indices_[a], indices_[b]);
  }

  // Moves the points of [begin, end) for which first(i) holds before the others; returns where the others
  // start (Hoare's scheme).
  template <class First>
  std::uint32_t partition_points(std::uint32_t begin, std::uint32_t end, First&& first) {
    for (;;) {
      while (begin < end && first(begin)) ++begin;
      while (begin < end && !first(end - 1)) --end;
      if (begin == end) return begin;
      swap_points(begin, end - 1);
      ++begin;
      --end;
    }
  }

  // Moves the points of [begin, end) below split_at on axis dim before the others; returns where the others
  // start. Which side a point falls on is a coin toss near the top of the tree, and mispredicted branches
  // were most of a build: this is Edelkamp and Weiss's block partition (BlockQuicksort), whose comparisons
  // only count, a block at each end at a time, before the misplaced pairs found are swapped. A block's
  // points are compared eight at a time into a bit mask, whose set bits' offsets come from a table.
  std::uint32_t partition_below(std::uint32_t begin, std::uint32_t end, unsigned dim, T split_at) {
    constexpr std::uint32_t kBlock = 64;
    const T* c = points_.data() + dim * n_;
    const std::array<std::uint64_t, 256>& offsets = set_bit_offsets();
    std::uint8_t misplaced_left[kBlock + 8], misplaced_right[kBlock + 8];  // + 8: a table entry's last write
    std::uint32_t n_left = 0, n_right = 0, from_left = 0, from_right = 0;
    std::uint32_t left = begin, right = end;  // [begin, left) is below, [right, end) is not
    while (right - left >= 2 * kBlock) {
      if (n_left == 0) {
        from_left = 0;
        for (std::uint32_t i = 0; i < kBlock; i += 8) {
          const unsigned mask = not_below_mask(c + left + i, split_at);
          const std::uint64_t at = offsets[mask] + i * 0x0101010101010101ull;
          std::memcpy(misplaced_left + n_left, &at, sizeof at);
          n_left += set_bits(mask);
        }
      }
      if (n_right == 0) {
        from_right = 0;
        for (std::uint32_t i = 0; i < kBlock; i += 8) {
          const unsigned mask = below_mask_downward(c + right - 1 - i, split_at);
          const std::uint64_t at = offsets[mask] + i * 0x0101010101010101ull;
          std::memcpy(misplaced_right + n_right, &at, sizeof at);
          n_right += set_bits(mask);
        }
      }
      const std::uint32_t swaps = std::min(n_left, n_right);
      for (std::uint32_t i = 0; i < swaps; ++i) {
        swap_points(left + misplaced_left[from_left + i], right - 1 - misplaced_right[from_right + i]);
      }
      n_left -= swaps;
      n_right -= swaps;
      from_left += swaps;
      from_right += swaps;
      if (n_left == 0) left += kBlock;
      if (n_right == 0) right -= kBlock;
    }
    // The rest (a block with misplaced points left in it is still inside [left, right)).
    return partition_rest(left, right, c, split_at);
  }

  // partition_points(left, right, below split_at) for fewer than 256 points, without its branches: the
  // points not below, from the left, are swapped pairwise with those below, from the right, until they meet.
  std::uint32_t partition_rest(std::uint32_t left, std::uint32_t right, const T* c, T split_at) {
    constexpr std::uint32_t kMax = 255;
    const std::uint32_t n = right - left;
    if (n > kMax) return partition_points(left, right, [&](std::uint32_t i) { return c[i] < split_at; });
    const std::array<std::uint64_t, 256>& offsets = set_bit_offsets();
    std::uint8_t not_below[kMax + 8], below[kMax + 8];
    std::uint32_t n_not_below = 0, n_below = 0, i = 0;
    for (; i + 8 <= n; i += 8) {
      const unsigned up = not_below_mask(c + left + i, split_at), down = below_mask_downward(c + right - 1 - i, split_at);
      const std::uint64_t at_up = offsets[up] + i * 0x0101010101010101ull, at_down = offsets[down] + i * 0x0101010101010101ull;
      std::memcpy(not_below + n_not_below, &at_up, sizeof at_up);
      std::memcpy(below + n_below, &at_down, sizeof at_down);
      n_not_below += set_bits(up);
      n_below += set_bits(down);
    }
    for (; i < n; ++i) {
      not_below[n_not_below] = static_cast<std::uint8_t>(i);
      n_not_below += !(c[left + i] < split_at);
      below[n_below] = static_cast<std::uint8_t>(i);
      n_below += c[right - 1 - i] < split_at;
    }
    for (std::uint32_t k = 0; k < n_not_below && k < n_below; ++k) {
      const std::uint32_t a = left + not_below[k], b = right - 1 - below[k];
      if (a >= b) break;
      swap_points(a, b);
    }
    return left + n_below;
  }

  // For each 8-bit mask, the offsets of its set bits, lowest first, one a byte.
  static const std::array<std::uint64_t, 256>& set_bit_offsets() {
    static const std::array<std::uint64_t, 256> table = [] {
      std::array<std::uint64_t, 256> t{};
      for (unsigned mask = 0; mask < 256; ++mask) {
        unsigned n = 0;
        for (unsigned b = 0; b < 8; ++b) {
          if ((mask >> b) & 1u) t[mask] |= std::uint64_t(b) << (8 * n++);
        }
      }
      return t;
    }();
    return table;
  }

  // The number of set bits of an 8-bit mask (baseline x86-64 has no POPCNT: the builtin calls libgcc).
  static std::uint32_t set_bits(unsigned mask) {
    static constexpr std::uint8_t kNibble[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    return kNibble[mask & 15u] + kNibble[mask >> 4];
  }

  // Bit j: whether c[j] is not below split_at (j < 8).
  static unsigned not_below_mask(const T* c, T split_at) {
#if defined(OURS_SSE2)
    if constexpr (std::is_same_v<T, double>) {
      const __m128d s = _mm_set1_pd(split_at);
      unsigned mask = 0;
      for (int j = 0; j < 8; j += 2) mask |= unsigned(_mm_movemask_pd(_mm_cmpnlt_pd(_mm_loadu_pd(c + j), s))) << j;
      return mask;
    } else {
      const __m128 s = _mm_set1_ps(split_at);
      return unsigned(_mm_movemask_ps(_mm_cmpnlt_ps(_mm_loadu_ps(c), s))) |
             unsigned(_mm_movemask_ps(_mm_cmpnlt_ps(_mm_loadu_ps(c + 4), s))) << 4;
    }
#else
    unsigned mask = 0;
    for (int j = 0; j < 8; ++j) mask |= unsigned(!(c[j] < split_at)) << j;
    return mask;
#endif
  }

  // Bit j: whether c[-j] is below split_at (j < 8: reading down from c).
  static unsigned below_mask_downward(const T* c, T split_at) {
#if defined(OURS_SSE2)
    if constexpr (std::is_same_v<T, double>) {
      const __m128d s = _mm_set1_pd(split_at);
      unsigned mask = 0;
      for (int j = 0; j < 8; j += 2) {
        const __m128d v = _mm_loadu_pd(c - j - 1);  // c[-j-1], c[-j]: swapped so that c[-j] is lane 0
        mask |= unsigned(_mm_movemask_pd(_mm_cmplt_pd(_mm_shuffle_pd(v, v, 1), s))) << j;
      }
      return mask;
    } else {
      const __m128 s = _mm_set1_ps(split_at);
      const __m128 hi = _mm_loadu_ps(c - 3), lo = _mm_loadu_ps(c - 7);
      constexpr int kReverse = _MM_SHUFFLE(0, 1, 2, 3);
      return unsigned(_mm_movemask_ps(_mm_cmplt_ps(_mm_shuffle_ps(hi, hi, kReverse), s))) |
             unsigned(_mm_movemask_ps(_mm_cmplt_ps(_mm_shuffle_ps(lo, lo, kReverse), s))) << 4;
    }
#else
    unsigned mask = 0;
    for (int j = 0; j < 8; ++j) mask |= unsigned(c[-j] < split_at) << j;
    return mask;
#endif
  }

  // Calls work(first, last) on [0, n) split in `threads` ranges, one thread each (this one when no other
  // can be started).
  template <class Work>
  static void on_threads(int threads, std::size_t n, Work&& work) {
    if (threads == 1 || n < kParallelPoints) return work(std::size_t(0), n);
    std::vector<std::thread> others;
    int started = 1;
    try {
      for (; started < threads; ++started) others.emplace_back(work, n * started / threads, n * (started + 1) / threads);
    } catch (const std::system_error&) {
    }
    work(std::size_t(0), n / threads);
    for (int t = started; t < threads; ++t) work(n * t / threads, n * (t + 1) / threads);
    for (auto& other : others) other.join();
  }

  // Nodes in pre-order, a right child's index counted from the first of them, and their greatest depth.
  struct Subtree {
    std::vector<Node> nodes;
    std::uint32_t max_depth = 0;
  };

  // Appends part's nodes to whole, their right children's indices shifted to where they land.
  static void append_subtree(Subtree& whole, const Subtree& part) {
    const std::size_t base = whole.nodes.size();
    if (base + part.nodes.size() >= (std::size_t(1) << 30)) throw std::length_error("ours::KdTree: too many nodes");
    for (Node node : part.nodes) {
      if (!node.is_leaf()) node.word += static_cast<std::uint32_t>(base) << 2;
      whole.nodes.push_back(node);
    }
    whole.max_depth = std::max(whole.max_depth, part.max_depth);
  }

  // Subtrees of fewer points are built on the thread that split them: starting a thread costs more.
  static constexpr std::uint32_t kParallelPoints = 1u << 16;

  // Builds the two children of a split, each into its own Subtree, the left one on another thread.
  void build_children_in_parallel(Subtree& out, std::uint32_t begin, std::uint32_t split, std::uint32_t end,
                                  const std::array<std::array<T, 3>, 4>& cells, std::uint32_t depth, int threads,
                                  std::size_t self, unsigned dim) {
    Subtree left, right;
    std::exception_ptr failed;
    const auto build_left = [&] {
      try {
        build_node(left, begin, split, cells[0], cells[1], depth + 1, threads / 2);
      } catch (...) {
        failed = std::current_exception();
      }
    };
    std::thread other;
    try {
      other = std::thread(build_left);
    } catch (const std::system_error&) {
      build_left();  // no thread to be had: one after the other
    }
    try {
      build_node(right, split, end, cells[2], cells[3], depth + 1, threads - threads / 2);
    } catch (...) {
      if (other.joinable()) other.join();
      throw;
    }
    if (other.joinable()) other.join();
    if (failed) std::rethrow_exception(failed);
    append_subtree(out, left);
    out.nodes[self].word = (static_cast<std::uint32_t>(out.nodes.size()) << 2) | dim;
    append_subtree(out, right);
  }

  // The axes from the cell's widest side to its narrowest; of equal sides the lower axis first.
  static std::array<int, 3> sides_widest_first(const std::array<T, 3>& lo, const std::array<T, 3>& hi) {
    std::array<int, 3> axes{0, 1, 2};
    const auto wider = [&](int a, int b) { return hi[a] - lo[a] > hi[b] - lo[b]; };
    if (wider(axes[1], axes[0])) std::swap(axes[0], axes[1]);
    if (wider(axes[2], axes[1])) std::swap(axes[1], axes[2]);
    if (wider(axes[1], axes[0])) std::swap(axes[0], axes[1]);
    return axes;
  }

  // Builds the subtree of the points [begin, end) inside the cell [lo, hi]: appends its nodes to out, on up
  // to `threads` threads.
  void build_node(Subtree& out, std::uint32_t begin, std::uint32_t end, std::array<T, 3> lo, std::array<T, 3> hi,
                  std::uint32_t depth, int threads) {
    out.max_depth = std::max(out.max_depth, depth);
    const std::uint32_t count = end - begin;
    // Sliding midpoint on the widest side of the cell; narrower sides when no float cut fits there. The
    // points' extent on a side decides whether it can be split at all (duplicates, flat clouds) and where
    // the cut slides to: measured side by side, only as far as the choice needs (a bucket needs none).
    int dim = -1;
    float cut = 0;
    if (count > bucket_size_) {
      const std::array<int, 3> by_width = sides_widest_first(lo, hi);
      for (const int d : by_width) {
        T pmin, pmax;
        extent(unsigned(d), begin, end, pmin, pmax);
        if (!(pmax > pmin)) continue;
        const T middle = std::clamp(lo[d] + (hi[d] - lo[d]) / 2, pmin, pmax);
        if (choose_cut(unsigned(d), middle, pmin, pmax, cut)) {
          dim = d;
          break;
        }
      }
    }
    if (dim < 0) {
      Node leaf;
      leaf.word = (count << 2) | 3u;
      leaf.bucket = begin;
      out.nodes.push_back(leaf);
      return;
    }
    const T split_at = plane(unsigned(dim), cut);
    const std::uint32_t eq_begin = partition_below(begin, end, unsigned(dim), split_at);
    // Points on the plane may go either way: balance them, but keep at least one point per side. They
    // are gathered only when the left side wants some (else none moves: a pass over the right saved).
    const std::uint32_t n_lt = eq_begin - begin;
    std::uint32_t n_le = n_lt;
    if ((n_lt < count / 2 || n_lt == 0) && any_on_plane(unsigned(dim), eq_begin, end, split_at)) {
      const T* c = points_.data() + std::size_t(dim) * n_;
      n_le = partition_points(eq_begin, end, [&](std::uint32_t i) { return c[i] == split_at; }) - begin;
    }
    std::uint32_t n_left = std::clamp(count / 2, n_lt, n_le);
    n_left = std::clamp<std::uint32_t>(n_left, 1, count - 1);
    const std::uint32_t split = begin + n_left;

    const std::size_t self = out.nodes.size();
    out.nodes.push_back(Node{});
    out.nodes[self].cut = cut;
    std::array<T, 3> left_hi = hi, right_lo = lo;
    left_hi[dim] = split_at;
    right_lo[dim] = split_at;
    if (threads > 1 && count >= 2 * kParallelPoints) {
      build_children_in_parallel(out, begin, split, end, {lo, left_hi, right_lo, hi}, depth, threads, self,
                                 static_cast<unsigned>(dim));
      return;
    }
    build_node(out, begin, split, lo, left_hi, depth + 1, 1);
    const std::size_t right = out.nodes.size();
    if (right >= (std::size_t(1) << 30)) throw std::length_error("ours::KdTree: too many nodes");
    out.nodes[self].word = (static_cast<std::uint32_t>(right) << 2) | static_cast<std::uint32_t>(dim);
    build_node(out, split, end, right_lo, hi, depth + 1, 1);
  }

  // The previous in-order query's first descent: its steps are in buffers.path[0, depth) and the cells
  // of their nodes in buffers.cells[0, depth], the last its leaf's: lo < p <= hi (a right child holds the
  // coordinates above its plane).
  struct LastDescent {
    bool valid = false;
    std::uint32_t depth = 0;
    std::uint32_t leaf = std::numeric_limits<std::uint32_t>::max();
    std::array<T, 3> lo, hi;
  };

  // Pushes the far child of a first-descent step when it lies within the bound (offsets: that one axis).
  // Here and in the descents, offsets and cells are written coordinate by coordinate from registers:
  // one coordinate written at an index known only at run time, then all three read back, stalls the
  // read until the write has left the store buffer.
  void push_far(const DescentStep<T>& step, T offset, T bound, PendingCell<T>*& top) const {
    if (offset * offset * shrink_ <= bound) {
      for (unsigned d = 0; d < 3; ++d) top->offsets[d] = d == step.dim ? offset : T(0);
      top->sq_dist = offset * offset;
      top->node = step.far;
      ++top;
    }
  }

  // Algorithm 3 for one query, starting from the previous query's first descent (last). Inside the
  // previous leaf's cell the path is the same: scan the leaf, and stop when the ball of the bound lies
  // inside the cell (every far child along the path is then beyond it too). Otherwise the path is the
  // same down to the first step the query leaves: far children within the bound are pushed from the
  // recorded planes, and the descent goes on from that node and is recorded. Returns whether the query
  // lay in the previous leaf.
  template <class Collect>
  bool search_after_last(const Query& q, Collect& collect, Buffers& buffers, LastDescent& last) const {
    DescentStep<T>* const path = buffers.path.data();
    PendingCell<T>* const bottom = buffers.pending.data();
    PendingCell<T>* top = bottom;
    if (last.valid && q.p[0] > last.lo[0] && q.p[0] <= last.hi[0] && q.p[1] > last.lo[1] && q.p[1] <= last.hi[1] &&
        q.p[2] > last.lo[2] && q.p[2] <= last.hi[2]) {
      scan_bucket(nodes_[last.leaf], q, collect);
      T wall = std::numeric_limits<T>::infinity();
      for (int d = 0; d < 3; ++d) wall = std::min({wall, q.p[d] - last.lo[d], last.hi[d] - q.p[d]});
      if (wall * wall * shrink_ > collect.bound()) return true;
      for (std::uint32_t l = 0; l < last.depth; ++l) {
        push_far(path[l], q.p[path[l].dim] - path[l].plane, collect.bound(), top);
      }
      search_pending(q, collect, bottom, top);
      return true;
    }
    const T limit = collect.bound();
    std::uint32_t level = 0;
    std::uint32_t index = 0;
    if (last.valid) {
      for (; level < last.depth; ++level) {
        const T offset = q.p[path[level].dim] - path[level].plane;
        if ((offset > 0) != path[level].right) break;
        push_far(path[level], offset, limit, top);
      }
      index = level < last.depth ? path[level].node : last.leaf;
    }
    // The shared steps' cells are kept: only the new steps' are worked out.
    CellBox<T>* const cells = buffers.cells.data();
    if (level == 0) {
      cells[0].lo.fill(-std::numeric_limits<T>::infinity());
      cells[0].hi.fill(std::numeric_limits<T>::infinity());
    }
    CellBox<T> cell = cells[level];
    Node node = nodes_[index];
    while (!node.is_leaf()) {
      DescentStep<T>& step = path[level++];
      step.dim = node.dim();
      step.plane = plane(step.dim, node.cut);
      step.node = index;
      const T offset = q.p[step.dim] - step.plane;
      step.right = offset > 0;
      step.far = step.right ? index + 1 : node.right_or_size();
      push_far(step, offset, limit, top);
      for (unsigned d = 0; d < 3; ++d) {
        const bool axis = d == step.dim;
        cell.lo[d] = axis && step.right ? std::max(cell.lo[d], step.plane) : cell.lo[d];
        cell.hi[d] = axis && !step.right ? std::min(cell.hi[d], step.plane) : cell.hi[d];
      }
      cells[level] = cell;
      index = step.right ? node.right_or_size() : index + 1;
      node = nodes_[index];
    }
    last.valid = true;
    last.depth = level;
    last.leaf = index;
    last.lo = cell.lo;
    last.hi = cell.hi;
    search_from(q, collect, index, bottom, top);
    return false;
  }

  // Up to kBatch searches between their first descent and the rest.
  struct Descents {
    std::array<Query, kBatch> q;
    std::array<T, kBatch> limit;                ///< each query's initial bound (m^2, in T)
    std::array<PendingCell<T>*, kBatch> top;    ///< each query's pending stack (its top)
    std::array<std::uint32_t, kBatch> leaf{};   ///< the leaf each query descended to
  };

  // The first descent of Algorithm 3 for m queries, interleaved and branch-free: from the root the
  // offsets are all zero and the near child inherits them, so each far child pushed has the single
  // offset of its own cut. A query that reached its leaf idles until all have.
  void descend(Descents& batch, std::size_t m) const {
    std::array<Node, kBatch> node;
    for (std::size_t j = 0; j < m; ++j) {
      batch.leaf[j] = 0;
      node[j] = nodes_[0];
    }
    for (bool active = true; active;) {
      active = false;
      for (std::size_t j = 0; j < m; ++j) {
        const Node nd = node[j];
        const std::uint32_t index = batch.leaf[j];
        const bool inner = !nd.is_leaf();
        // A leaf's second word is a bucket index, not a float: read it as 0 (no denormal stalls).
        const unsigned dim = inner ? nd.dim() : 0u;
        const float cut = inner ? nd.cut : 0.0f;
        const T new_off = batch.q[j].p[dim] - plane(dim, cut);
        const bool go_right = new_off > 0;
        PendingCell<T>* const top = batch.top[j];
        for (unsigned d = 0; d < 3; ++d) top->offsets[d] = d == dim ? new_off : T(0);
        top->sq_dist = new_off * new_off;
        top->node = go_right ? index + 1 : nd.right_or_size();
        batch.top[j] = top + (inner && top->sq_dist * shrink_ <= batch.limit[j] ? 1 : 0);
        const std::uint32_t next = go_right ? nd.right_or_size() : index + 1;
        batch.leaf[j] = inner ? next : index;
        node[j] = nodes_[batch.leaf[j]];
        active |= inner;
      }
    }
  }

  // The rest of Algorithm 3 once the first descent reached its leaf: scan that leaf, then the pending cells.
  template <class Collect>
  void search_from(const Query& q, Collect& collect, std::uint32_t leaf, PendingCell<T>* const bottom,
                   PendingCell<T>* top) const {
    scan_bucket(nodes_[leaf], q, collect);
    search_pending(q, collect, bottom, top);
  }

  // Algorithm 3 without recursion: pop the next pending cell still within the bound, descend from it
  // (pushing each far child with its offsets, per-axis distance parts, and their squared norm), scan
  // the leaf, repeat. The pushes are branch-free: written always, kept when within the bound. shrink_
  // absorbs the rounding of the incremental update, so no point at the bound is lost.
  template <class Collect>
  void search_pending(const Query& q, Collect& collect, PendingCell<T>* const bottom, PendingCell<T>* top) const {
    for (;;) {
      do {
        if (top == bottom) return;
        --top;
      } while (top->sq_dist * shrink_ > collect.bound());
      std::array<T, 3> offsets = top->offsets;
      const T rd = top->sq_dist;
      std::uint32_t index = top->node;
      Node node = nodes_[index];
      while (!node.is_leaf()) {
        const unsigned dim = node.dim();
        const T new_off = q.p[dim] - plane(dim, node.cut);
        const std::uint32_t right = node.right_or_size();
        const bool go_right = new_off > 0;
        const T far_rd = rd - offsets[dim] * offsets[dim] + new_off * new_off;
        for (unsigned d = 0; d < 3; ++d) top->offsets[d] = d == dim ? new_off : offsets[d];
        top->sq_dist = far_rd;
        top->node = go_right ? index + 1 : right;
        top += far_rd * shrink_ <= collect.bound() ? 1 : 0;
        index = go_right ? right : index + 1;
        node = nodes_[index];
      }
      scan_bucket(node, q, collect);
    }
  }

  template <class Collect>
  void scan_bucket(const Node& leaf, const Query& q, Collect& collect) const {
    const std::uint32_t begin = leaf.bucket;
    const std::uint32_t end = begin + leaf.right_or_size();
    const T* xs = points_.data();
    scan_points(xs, xs + n_, xs + 2 * n_, indices_.data(), begin, end, q.p, collect);
  }

  std::vector<Node> nodes_;
  std::vector<T, DefaultInit<T>> points_;
  std::vector<std::uint32_t, DefaultInit<std::uint32_t>> indices_;
  std::array<double, 3> origin_{0, 0, 0};
  std::size_t n_ = 0;
  std::uint32_t bucket_size_ = 8;
  std::uint32_t max_depth_ = 0;
  T shrink_ = 1;
};

}  // namespace ours
