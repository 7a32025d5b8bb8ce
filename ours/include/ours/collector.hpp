#pragma once
// What the k-d tree and the octree share: candidates, the k-best collectors (a linear heap for small
// k, a binary heap for large k, as libnabo), the error model that makes a float search safe, and the
// per-caller buffers of the answer.
//
// Exactness. Both trees compute distances in their scalar T. With T = double and no origin shift the
// distance of a point is computed exactly as nnb::sq_dist_m2, so the answer is the exact answer. With
// T = float the search is "conservative": it keeps every candidate whose float distance could belong
// to the exact double answer (within a slack S(x) of the k-th distance and of the limit), and the caller
// recomputes distances in double, filters and keeps the k nearest.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <limits>
#include <type_traits>
#include <vector>

// The x86 vector paths (SSE2 at compile time, AVX2 chosen at run time); every other CPU takes the plain
// C++ beside them, which -DOURS_PORTABLE selects on x86 too, so that a test can check it here.
#if defined(__SSE2__) && !defined(OURS_PORTABLE)
#include <emmintrin.h>
#define OURS_SSE2 1
#endif
#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && !defined(OURS_PORTABLE)
#include <immintrin.h>
#define OURS_WIDE_SIMD 1
#endif

namespace ours {

/// Maps in the pages of a fresh block of `bytes` bytes at `data` in one call, before a build writes
/// them. Where a page fault is dear (about 11 us in some virtual machines, against 0.7 us a page mapped
/// in one call) a 16M-point build spent two thirds of its time faulting its arrays in page by page.
/// Small blocks are left alone, and so is a block whose last page is already mapped: the allocator
/// reused it, and walking it again would only cost time. Where the call is missing or refused, the pages
/// fault in on first write as before; nothing else changes.
inline void populate_for_write(void* data, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::size_t kMinBytes = std::size_t{1} << 20;
  if (data == nullptr || bytes < kMinBytes) return;
  const long page_size = sysconf(_SC_PAGESIZE);
  if (page_size <= 0) return;
  const auto page = static_cast<std::uintptr_t>(page_size);
  const auto first = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t begin = (first + page - 1) & ~(page - 1);
  const std::uintptr_t end = (first + bytes) & ~(page - 1);
  if (end <= begin) return;
  unsigned char last_page_mapped = 0;
  if (mincore(reinterpret_cast<void*>(end - page), page, &last_page_mapped) == 0 && (last_page_mapped & 1))
    return;
  madvise(reinterpret_cast<void*>(begin), end - begin, MADV_POPULATE_WRITE);
#else
  (void)data;
  (void)bytes;
#endif
}

/// The standard allocator, except that resize() leaves numbers uninitialised (a build writes every
/// coordinate and index at once, and zeroing hundreds of megabytes first only costs time), and that
/// large fresh blocks are mapped in at once (populate_for_write). Large blocks are not advised for
/// transparent huge pages: where the host takes freed 2 MB blocks back (a VM's free page reporting), a
/// first touch of a huge page faults on the host too, and a 16M-point build then took twice as long as
/// with 4 KB pages, while it gained a fifth where huge pages were at hand.
template <typename U>
struct DefaultInit : std::allocator<U> {
  template <typename V>
  struct rebind {
    using other = DefaultInit<V>;
  };
  DefaultInit() = default;
  template <typename V>
  DefaultInit(const DefaultInit<V>&) noexcept {}

  U* allocate(std::size_t n) {
    U* data = std::allocator<U>::allocate(n);
    populate_for_write(data, n * sizeof(U));
    return data;
  }

  template <typename V, typename... Args>
  void construct(V* at, Args&&... args) {
    if constexpr (sizeof...(Args) == 0) ::new (static_cast<void*>(at)) V;
    else ::new (static_cast<void*>(at)) V(std::forward<Args>(args)...);
  }
};

/// Raw memory from DefaultInit that holds arrays of different types in
/// turn: as<U>() starts the lifetime of an array of U (ending whatever lived there). A build's scratch
/// arrays can then live in the pages of its final arrays, which are faulted in once instead of twice.
class ReusableBlock {
 public:
  ReusableBlock() = default;
  ReusableBlock(const ReusableBlock&) = delete;
  ReusableBlock& operator=(const ReusableBlock&) = delete;
  ReusableBlock(ReusableBlock&& other) noexcept { swap(other); }
  ReusableBlock& operator=(ReusableBlock&& other) noexcept {
    swap(other);
    return *this;
  }
  ~ReusableBlock() { release(); }

  /// Replaces the memory by a block of at least `bytes` bytes, aligned for any scalar.
  void assign(std::size_t bytes) {
    release();
    words_ = (bytes + sizeof(Word) - 1) / sizeof(Word);
    if (words_ > 0) data_ = DefaultInit<Word>().allocate(words_);
  }
  void release() {
    if (data_) DefaultInit<Word>().deallocate(data_, words_);
    data_ = nullptr;
    words_ = 0;
  }

  /// Starts `count` Us (left uninitialised) at byte `offset`, a multiple of alignof(U), and returns the first.
  template <typename U>
  U* as(std::size_t offset, std::size_t count) {
    static_assert(std::is_trivially_destructible_v<U> && alignof(U) <= alignof(Word), "plain scalars only");
    U* first = reinterpret_cast<U*>(reinterpret_cast<unsigned char*>(data_) + offset);
    std::uninitialized_default_construct_n(first, count);
    return std::launder(first);
  }

 private:
  using Word = std::uint64_t;
  void swap(ReusableBlock& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(words_, other.words_);
  }
  Word* data_ = nullptr;
  std::size_t words_ = 0;
};

/// The bounding box (lo, hi) of n > 0 points (x,y,z triples), two points a step: six independent
/// running minima and maxima instead of three chains of dependent ones.
inline void bounding_box(const double* xyz, std::size_t n, std::array<double, 3>& lo, std::array<double, 3>& hi) {
  std::array<double, 6> low, high;
  for (int d = 0; d < 6; ++d) low[d] = high[d] = xyz[d % 3];
  std::size_t i = 0;
  for (; i + 2 <= n; i += 2) {
    for (int d = 0; d < 6; ++d) {
      low[d] = std::min(low[d], xyz[3 * i + d]);
      high[d] = std::max(high[d], xyz[3 * i + d]);
    }
  }
  for (; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      low[d] = std::min(low[d], xyz[3 * i + d]);
      high[d] = std::max(high[d], xyz[3 * i + d]);
    }
  }
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::min(low[d], low[d + 3]);
    hi[d] = std::max(high[d], high[d + 3]);
  }
}

/// Points are scanned in blocks of at most this many: distances first (vectorised), then the collector.
constexpr std::uint32_t kScanBlock = 64;

namespace detail {
/// The points [i, m) one at a time, as sq_dist_m2 computes them; returns the minimum of best and theirs.
template <typename T>
inline T scan_tail(const T* xs, const T* ys, const T* zs, std::uint32_t i, std::uint32_t m, const std::array<T, 3>& q,
                   T* __restrict sq, T best) {
  for (; i < m; ++i) {
    const T dx = q[0] - xs[i];
    const T dy = q[1] - ys[i];
    const T dz = q[2] - zs[i];
    sq[i] = dx * dx + dy * dy + dz * dz;
    best = std::min(best, sq[i]);
  }
  return best;
}

#if defined(OURS_WIDE_SIMD)
// Four points at a time, chosen at run time so the binary stays portable. Built for AVX2 alone, not FMA:
// a fused multiply-add would round differently from sq_dist_m2.
__attribute__((target("avx2"))) inline double block_sq_dists_avx2(const double* xs, const double* ys,
                                                                    const double* zs, std::uint32_t m,
                                                                    const std::array<double, 3>& q,
                                                                    double* __restrict sq) {
  const __m256d qx = _mm256_set1_pd(q[0]), qy = _mm256_set1_pd(q[1]), qz = _mm256_set1_pd(q[2]);
  __m256d low = _mm256_set1_pd(std::numeric_limits<double>::infinity());
  std::uint32_t i = 0;
  for (; i + 4 <= m; i += 4) {
    const __m256d dx = _mm256_sub_pd(qx, _mm256_loadu_pd(xs + i));
    const __m256d dy = _mm256_sub_pd(qy, _mm256_loadu_pd(ys + i));
    const __m256d dz = _mm256_sub_pd(qz, _mm256_loadu_pd(zs + i));
    const __m256d d2 =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
    _mm256_storeu_pd(sq + i, d2);
    low = _mm256_min_pd(low, d2);
  }
  const __m128d half = _mm_min_pd(_mm256_castpd256_pd128(low), _mm256_extractf128_pd(low, 1));
  const double best = std::min(_mm_cvtsd_f64(half), _mm_cvtsd_f64(_mm_unpackhi_pd(half, half)));
  return scan_tail(xs, ys, zs, i, m, q, sq, best);
}

/// Whether this CPU (and its OS) runs AVX2; read once, at start-up.
inline const bool kHasAvx2 = [] {
  __builtin_cpu_init();  // static initialisers may run before libgcc's own
  return __builtin_cpu_supports("avx2") != 0;
}();
#endif

/// block_sq_dists on every x86-64 (SSE2) and elsewhere (scalar).
template <typename T>
inline T block_sq_dists_portable(const T* xs, const T* ys, const T* zs, std::uint32_t m, const std::array<T, 3>& q,
                                 T* __restrict sq) {
  T best = std::numeric_limits<T>::infinity();
  std::uint32_t i = 0;
#if defined(OURS_SSE2)
  if constexpr (std::is_same_v<T, double>) {
    // One pass: distances, stored, and their running minimum, two points at a time.
    const __m128d qx = _mm_set1_pd(q[0]), qy = _mm_set1_pd(q[1]), qz = _mm_set1_pd(q[2]);
    __m128d low = _mm_set1_pd(best);
    for (; i + 2 <= m; i += 2) {
      const __m128d dx = _mm_sub_pd(qx, _mm_loadu_pd(xs + i));
      const __m128d dy = _mm_sub_pd(qy, _mm_loadu_pd(ys + i));
      const __m128d dz = _mm_sub_pd(qz, _mm_loadu_pd(zs + i));
      const __m128d d2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
      _mm_storeu_pd(sq + i, d2);
      low = _mm_min_pd(low, d2);
    }
    best = std::min(_mm_cvtsd_f64(low), _mm_cvtsd_f64(_mm_unpackhi_pd(low, low)));
  } else {
    for (std::uint32_t j = 0; j < m; ++j) {
      const T dx = q[0] - xs[j];
      const T dy = q[1] - ys[j];
      const T dz = q[2] - zs[j];
      sq[j] = dx * dx + dy * dy + dz * dz;
    }
    __m128 a = _mm_set1_ps(best), b = a;
    for (; i + 8 <= m; i += 8) {
      a = _mm_min_ps(a, _mm_loadu_ps(sq + i));
      b = _mm_min_ps(b, _mm_loadu_ps(sq + i + 4));
    }
    alignas(16) float lanes[4];
    _mm_store_ps(lanes, _mm_min_ps(a, b));
    best = std::min(std::min(lanes[0], lanes[1]), std::min(lanes[2], lanes[3]));
    for (; i < m; ++i) best = std::min(best, sq[i]);
    return best;
  }
#endif
  return scan_tail(xs, ys, zs, i, m, q, sq, best);
}
}  // namespace detail

/// Writes the squared distances (m^2, in T) from q to m <= kScanBlock points given as separate x, y, z
/// arrays into sq, and returns their minimum. Each is computed as nnb::sq_dist_m2 computes it, so a
/// double tree's distances stay bit-exact; the minimum is taken in vector registers (GCC does not
/// vectorise a floating-point min reduction without -ffast-math).
template <typename T>
inline T block_sq_dists(const T* xs, const T* ys, const T* zs, std::uint32_t m, const std::array<T, 3>& q,
                        T* __restrict sq) {
#if defined(OURS_WIDE_SIMD)
  if constexpr (std::is_same_v<T, double>) {
    if (detail::kHasAvx2) return detail::block_sq_dists_avx2(xs, ys, zs, m, q, sq);
  }
#endif
  return detail::block_sq_dists_portable(xs, ys, zs, m, q, sq);
}

/// Returns the position of the first of sq[0, m) equal to value (m when none is).
template <typename T>
inline std::uint32_t find_first(const T* sq, std::uint32_t m, T value) {
  std::uint32_t i = 0;
#if defined(OURS_SSE2)
  if constexpr (std::is_same_v<T, double>) {
    const __m128d v = _mm_set1_pd(value);
    for (; i + 4 <= m; i += 4) {
      const int mask = _mm_movemask_pd(_mm_cmpeq_pd(_mm_loadu_pd(sq + i), v)) |
                       (_mm_movemask_pd(_mm_cmpeq_pd(_mm_loadu_pd(sq + i + 2), v)) << 2);
      if (mask != 0) return i + static_cast<std::uint32_t>(__builtin_ctz(static_cast<unsigned>(mask)));
    }
  }
#endif
  for (; i < m; ++i) {
    if (sq[i] == value) return i;
  }
  return m;
}

/// Offers points [begin, end) (tree order; coordinates as separate x, y, z arrays, model indices in
/// indices) to collect, block by block: a block whose nearest point is beyond the bound costs one
/// comparison.
template <typename T, class Collect>
inline void scan_points(const T* xs, const T* ys, const T* zs, const std::uint32_t* indices, std::uint32_t begin,
                        std::uint32_t end, const std::array<T, 3>& q, Collect& collect) {
  T sq[kScanBlock];
  for (std::uint32_t at = begin; at < end; at += kScanBlock) {
    const std::uint32_t m = std::min(kScanBlock, end - at);
    const T nearest = block_sq_dists(xs + at, ys + at, zs + at, m, q, sq);
    if (nearest <= collect.bound()) collect.offer_block(sq, indices + at, m, nearest);
  }
}

/// One neighbour: its index in the model and its squared distance (square metres, in T).
template <typename T>
struct Neighbour {
  T sq_dist;
  std::uint32_t index;
};

/// Reusable per-caller buffers, so that a batch of queries allocates nothing per query. A tree that needs
/// more scratch derives its own (Tree::Buffers).
template <typename T>
struct SearchBuffers {
  std::vector<Neighbour<T>> best;    ///< the k best so far
  std::vector<Neighbour<T>> extras;  ///< float only: near misses that may still belong to the answer
};

/// Linear heaps pay O(k) per insertion with a tiny constant; the paper found them faster up to k = 30.
constexpr int kLinearHeapMaxK = 30;

/// The float error model. For float coordinates stored relative to an origin, with the query's largest
/// coordinate magnitude m (metres, relative to that origin), |float sq_dist - exact sq_dist| stays
/// below about 21 u (m^2 + d) with u = 2^-24 (5.9604645e-8); slack() allows 128 u, about six times that
/// bound, since the bound itself is a first-order estimate.
template <typename T>
struct ErrorModel {
  static constexpr bool kConservative = std::is_same_v<T, float>;
  T abs_m2 = 0;  ///< m^2 of the query
  /// Returns the slack (m^2) to allow above a float squared distance x (m^2); 0 for double.
  T slack(T x) const {
    if constexpr (kConservative) {
      return T(128) * T(5.9604645e-8) * (abs_m2 + x);
    } else {
      (void)x;
      return T(0);
    }
  }
};

/// Relative safety factor on incrementally updated cell bounds. A cell's squared distance starts as one
/// squared offset and is updated once a level, rd - old_off^2 + new_off^2 with new_off = q - plane: about
/// 5 u of relative error, and the value only grows along a path (a deeper plane on an axis is no nearer
/// than the wall it replaces), so the errors add up relative to the final value. Each of the `steps`
/// updates (the tree's depth) is allowed 8 u, and 8 steps more cover the first square and the product with
/// the factor; a pruning test against bound * shrink is then never wrong. The cap at 0.5 keeps the factor
/// positive; in float it binds only past a million levels.
template <typename T>
inline T bound_shrink(int steps) {
  const double u = std::is_same_v<T, float> ? 5.9604645e-8 : 1.1102230246251565e-16;
  return T(1.0 - std::min(0.5, 8.0 * u * (steps + 8)));
}

/// Returns a 4-bit mask of which of sq[0, 4) are <= bound (a NaN is not).
template <typename T>
inline unsigned at_most_mask(const T* sq, T bound) {
#if defined(OURS_SSE2)
  if constexpr (std::is_same_v<T, double>) {
    const __m128d b = _mm_set1_pd(bound);
    return static_cast<unsigned>(_mm_movemask_pd(_mm_cmple_pd(_mm_loadu_pd(sq), b)) |
                                 (_mm_movemask_pd(_mm_cmple_pd(_mm_loadu_pd(sq + 2), b)) << 2));
  } else {
    return static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(sq), _mm_set1_ps(bound))));
  }
#else
  unsigned mask = 0;
  for (unsigned j = 0; j < 4; ++j) mask |= unsigned(sq[j] <= bound) << j;
  return mask;
#endif
}

/// Returns the smallest of v[0, m) that is a number (+infinity when none is).
template <typename T>
inline T min_of_numbers(const T* v, std::uint32_t m) {
  T low = std::numeric_limits<T>::infinity();
  std::uint32_t i = 0;
#if defined(OURS_SSE2)
  if constexpr (std::is_same_v<T, double>) {
    // minpd returns its second operand when the first is NaN: the running minimum goes second.
    __m128d a = _mm_set1_pd(low), b = a;
    for (; i + 4 <= m; i += 4) {
      a = _mm_min_pd(_mm_loadu_pd(v + i), a);
      b = _mm_min_pd(_mm_loadu_pd(v + i + 2), b);
    }
    const __m128d ab = _mm_min_pd(a, b);
    low = std::min(_mm_cvtsd_f64(ab), _mm_cvtsd_f64(_mm_unpackhi_pd(ab, ab)));
  }
#endif
  for (; i < m; ++i) {
    if (v[i] < low) low = v[i];
  }
  return low;
}

/// Collects the k nearest candidates within limit_sq. Linear = sorted array, else binary max-heap.
template <typename T, bool Linear>
class Collector {
 public:
  Collector(SearchBuffers<T>& buffers, int k, T limit_sq, ErrorModel<T> error)
      : best_(buffers.best), extras_(buffers.extras), k_(static_cast<std::size_t>(k)), limit_sq_(limit_sq),
        error_(error) {
    best_.clear();
    extras_.clear();
    bound_ = limit_sq_;
  }

  /// Returns the squared distance (m^2) beyond which nothing can enter the answer (prune above it).
  T bound() const { return bound_; }

  /// Offers one point; the caller has already checked sq_dist <= bound().
  void offer(T sq_dist, std::uint32_t index) {
    if (best_.size() < k_) {
      insert({sq_dist, index});
      if (best_.size() == k_) update_bound();
      return;
    }
    if (sq_dist < kth()) {
      if constexpr (ErrorModel<T>::kConservative) extras_.push_back(evict());
      else evict();
      insert({sq_dist, index});
      update_bound();
    } else if constexpr (ErrorModel<T>::kConservative) {
      extras_.push_back({sq_dist, index});
    }
  }

  /// Offers m points with squared distances sq (m^2) and model indices index, whose smallest, nearest,
  /// the caller found <= bound(); sq is scratch, left changed. Offered in block order, a full heap would
  /// take every point nearer than its bound one after the other (a handful a block). An exact search for
  /// few neighbours offers the block's points nearest first instead, and stops after k or at the first
  /// beyond the bound: nothing after them can enter. Otherwise (many neighbours; a float search, which
  /// keeps near misses too) every point within the bound is offered, four compared at a time.
  void offer_block(T* sq, const std::uint32_t* index, std::uint32_t m, T nearest) {
    if constexpr (!ErrorModel<T>::kConservative) {
      if (k_ <= kNearestFirstMaxK) return offer_nearest_first(sq, index, m, nearest);
    }
    for (std::uint32_t i = 0; i + 4 <= m; i += 4) {
      for (unsigned mask = at_most_mask(sq + i, bound_); mask != 0; mask &= mask - 1) {
        const std::uint32_t at = i + static_cast<std::uint32_t>(__builtin_ctz(mask));
        if (sq[at] <= bound_) offer(sq[at], index[at]);
      }
    }
    for (std::uint32_t i = m & ~3u; i < m; ++i) {
      if (sq[i] <= bound_) offer(sq[i], index[i]);
    }
  }

  /// Moves the answer into buffers.best, nearest first (float: plus every near miss, unsorted tail).
  void finish() {
    if constexpr (!Linear) std::sort_heap(best_.begin(), best_.end(), by_dist);
    if constexpr (ErrorModel<T>::kConservative) {
      for (const auto& e : extras_) {
        if (e.sq_dist <= bound_) best_.push_back(e);
      }
    }
  }

 private:
  static bool by_dist(const Neighbour<T>& a, const Neighbour<T>& b) { return a.sq_dist < b.sq_dist; }

  // Up to this k a pass over the block per neighbour costs less than offering every point that passes.
  static constexpr std::size_t kNearestFirstMaxK = 8;

  void offer_nearest_first(T* sq, const std::uint32_t* index, std::uint32_t m, T nearest) {
    for (std::size_t offered = 0;;) {
      const std::uint32_t at = find_first(sq, m, nearest);
      if (at == m) return;
      offer(nearest, index[at]);
      if (++offered == std::min<std::size_t>(k_, m)) return;
      sq[at] = std::numeric_limits<T>::quiet_NaN();  // taken: no minimum sees it again
      nearest = min_of_numbers(sq, m);
      if (!(nearest <= bound_)) return;
    }
  }

  T kth() const { return Linear ? best_.back().sq_dist : best_.front().sq_dist; }

  void update_bound() {
    const T kth_sq = kth();
    bound_ = std::min(limit_sq_, kth_sq + error_.slack(kth_sq));
  }

  void insert(Neighbour<T> n) {
    if constexpr (Linear) {
      best_.push_back(n);
      std::size_t i = best_.size() - 1;
      while (i > 0 && best_[i - 1].sq_dist > n.sq_dist) {
        best_[i] = best_[i - 1];
        --i;
      }
      best_[i] = n;
    } else {
      best_.push_back(n);
      std::push_heap(best_.begin(), best_.end(), by_dist);
    }
  }

  Neighbour<T> evict() {
    if constexpr (Linear) {
      const Neighbour<T> last = best_.back();
      best_.pop_back();
      return last;
    } else {
      std::pop_heap(best_.begin(), best_.end(), by_dist);
      const Neighbour<T> last = best_.back();
      best_.pop_back();
      return last;
    }
  }

  std::vector<Neighbour<T>>& best_;
  std::vector<Neighbour<T>>& extras_;
  std::size_t k_;
  T limit_sq_;
  ErrorModel<T> error_;
  T bound_;
};

/// The nearest point within limit_sq (exact scalars only: a float search needs Collector's near misses).
/// 1-NN is what ICP asks for, so it gets a collector without a heap.
template <typename T>
class NearestCollector {
  static_assert(!ErrorModel<T>::kConservative, "float searches keep near misses: use Collector");

 public:
  NearestCollector(SearchBuffers<T>& buffers, T limit_sq) : best_(buffers.best), bound_(limit_sq) {
    best_.clear();
  }
  T bound() const { return bound_; }
  void offer(T sq_dist, std::uint32_t index) {
    bound_ = sq_dist;  // the caller checked sq_dist <= bound(): it is the new best
    index_ = index;
    found_ = true;
  }
  /// Offers m points whose smallest squared distance, nearest (m^2), the caller found <= bound().
  void offer_block(const T* sq, const std::uint32_t* index, std::uint32_t m, T nearest) {
    offer(nearest, index[std::min(find_first(sq, m, nearest), m - 1)]);
  }
  /// Field by field: a pair built on the stack and copied as one 16-byte load waited on its two stores.
  void finish() {
    if (!found_) return;
    Neighbour<T>& nearest = best_.emplace_back();
    nearest.sq_dist = bound_;
    nearest.index = index_;
  }

 private:
  std::vector<Neighbour<T>>& best_;
  T bound_;
  std::uint32_t index_ = 0;
  bool found_ = false;
};

/// Every point within limit_sq, in the order found.
template <typename T>
class RadiusCollector {
 public:
  RadiusCollector(SearchBuffers<T>& buffers, T limit_sq) : best_(buffers.best), limit_sq_(limit_sq) {
    best_.clear();
  }
  T bound() const { return limit_sq_; }
  void offer(T sq_dist, std::uint32_t index) { best_.push_back({sq_dist, index}); }
  void offer_block(const T* sq, const std::uint32_t* index, std::uint32_t m, T) {
    for (std::uint32_t i = 0; i < m; ++i) {
      if (sq[i] <= limit_sq_) best_.push_back({sq[i], index[i]});
    }
  }
  void finish() {}

 private:
  std::vector<Neighbour<T>>& best_;
  T limit_sq_;
};

/// Returns the limit (m^2, in T) a search must use so that nothing within limit_sq_m2 (exact, double)
/// is lost to float rounding; for double, the limit itself.
template <typename T>
inline T search_limit(double limit_sq_m2, const ErrorModel<T>& error) {
  if (!std::isfinite(limit_sq_m2)) return std::numeric_limits<T>::infinity();
  if constexpr (ErrorModel<T>::kConservative) {
    const double limit = limit_sq_m2 + 2.0 * double(error.slack(T(limit_sq_m2)));
    return limit > double(std::numeric_limits<T>::max()) ? std::numeric_limits<T>::infinity() : T(limit);
  } else {
    return limit_sq_m2;
  }
}

/// Runs search(collect) for the k nearest within limit_sq_m2 (m^2) with the collector that fits k (the
/// paper's choice: a plain minimum for 1-NN in double, a linear heap up to kLinearHeapMaxK, a binary heap
/// above), then finishes it into buffers.best.
template <typename T, class Search>
inline void collect_knn(int k, double limit_sq_m2, const ErrorModel<T>& error, SearchBuffers<T>& buffers,
                        Search&& search) {
  buffers.best.clear();
  buffers.extras.clear();
  const T limit = search_limit(limit_sq_m2, error);
  if constexpr (!ErrorModel<T>::kConservative) {
    if (k == 1) {
      NearestCollector<T> nearest(buffers, limit);
      search(nearest);
      nearest.finish();
      return;
    }
  }
  if (k <= kLinearHeapMaxK) {
    Collector<T, true> heap(buffers, k, limit, error);
    search(heap);
    heap.finish();
  } else {
    Collector<T, false> heap(buffers, k, limit, error);
    search(heap);
    heap.finish();
  }
}

}  // namespace ours
