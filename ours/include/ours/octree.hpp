#pragma once
// A compact octree after 3DTK (Elseberg et al. 2012, section 3.1, Algorithms 1 and 2).
//
// Nodes are 8 bytes. An inner node holds a bitmask of its non-empty children, a bitmask of which of
// them are leaves, and the index of its first child: the children of a node are stored together, so
// child j sits at first + popcount(valid & ((1 << j) - 1)). A leaf node holds its point count and the
// index of its first point; the points of a leaf are stored together (copied, in tree order).
//
// Search (exact). The query and its search box (query +- sqrt(current bound)) are converted once to
// integer octree coordinates; the search descends directly to the deepest node that contains the box
// (Algorithm 1), then visits children nearest first (Algorithm 2), ordered by a lower bound of their
// distance in integer units, and leaves a node at its first child beyond the ball. Floating point is
// used in leaves, and to shrink the ball when a leaf improved the bound. In a batch, the path to each
// query's own leaf starts from the previous query's: scan-ordered queries mostly share all of it.
#include "ours/collector.hpp"
#include "ours/query_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace ours {

/// Returns the number of set bits of an 8-bit mask (a table: no libgcc call without -mpopcnt).
inline std::uint32_t popcount8(unsigned mask) {
  static constexpr auto kBits = [] {
    std::array<std::uint8_t, 256> bits{};
    for (unsigned i = 1; i < 256; ++i) bits[i] = static_cast<std::uint8_t>(bits[i >> 1] + (i & 1u));
    return bits;
  }();
  return kBits[mask & 0xffu];
}

template <typename T>
class Octree {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "Octree<float> or Octree<double>");

 public:
  /// What a caller keeps between queries (one per thread).
  using Buffers = SearchBuffers<T>;

  /// Integer coordinates have this many bits per axis: the deepest possible level.
  static constexpr int kMaxLevel = 20;

  struct Node {
    std::uint32_t word;   ///< inner: valid mask | leaf mask << 8; leaf: number of points
    std::uint32_t first;  ///< inner: index of the first child node; leaf: index of the first point
    unsigned valid() const { return word & 0xffu; }
    unsigned leaves() const { return (word >> 8) & 0xffu; }
  };
  static_assert(sizeof(Node) == 8, "compact node");

  /// Builds over n points given as x,y,z triples (metres, double). A cell becomes a leaf when it holds
  /// at most max_points_per_leaf points, or its children would be smaller than min_cell_size_m (metres),
  /// or it reached kMaxLevel.
  void build(const double* xyz, std::size_t n, int max_points_per_leaf, double min_cell_size_m) {
    if (max_points_per_leaf < 1) throw std::invalid_argument("ours::Octree: max_points_per_leaf must be >= 1");
    if (!(min_cell_size_m >= 0)) throw std::invalid_argument("ours::Octree: min_cell_size_m must be >= 0");
    if (n >= (std::size_t(1) << 32) - 1) throw std::invalid_argument("ours::Octree: too many points");
    nodes_.clear();
    point_block_.release();
    points_ = nullptr;
    indices_.clear();
    n_ = n;
    max_points_ = static_cast<std::uint32_t>(max_points_per_leaf);
    min_cell_m_ = min_cell_size_m;
    origin_ = {0, 0, 0};
    if (n == 0) return;
    std::array<double, 3> lo, hi;
    bounding_box(xyz, n, lo, hi);
    side_m_ = 0;
    for (int d = 0; d < 3; ++d) side_m_ = std::max(side_m_, hi[d] - lo[d]);
    if (!(side_m_ > 0)) side_m_ = 1;  // one point or all duplicates: any cube will do
    for (int d = 0; d < 3; ++d) {
      cube_lo_[d] = lo[d];
      if constexpr (std::is_same_v<T, float>) origin_[d] = 0.5 * (lo[d] + hi[d]);
    }
    scale_ = double(1u << kMaxLevel) / side_m_;

    // Each point's cell as one Morton key (bit 3b + d is bit b of axis d), moved along with its index:
    // a level's pass then reads its keys in order instead of three coordinates from all over the cloud.
    // The keys and the pass's scratch live in the points' block until the points are gathered into it
    // (double: 20 of its 24 bytes a point; page faults were half of a 16M-point build).
    const std::size_t point_bytes = 3 * n * sizeof(T), sort_bytes = n * (2 * sizeof(std::uint64_t) + sizeof(std::uint32_t));
    point_block_.assign(point_bytes);
    ReusableBlock own_sort_block;
    ReusableBlock& sort_block = sort_bytes <= point_bytes ? point_block_ : (own_sort_block.assign(sort_bytes), own_sort_block);
    std::uint64_t* const keys = sort_block.as<std::uint64_t>(0, n);
    std::uint64_t* const key_scratch = sort_block.as<std::uint64_t>(n * sizeof(std::uint64_t), n);
    std::uint32_t* const scratch = sort_block.as<std::uint32_t>(2 * n * sizeof(std::uint64_t), n);
    Scratch<std::uint32_t> order(n);
    for (std::size_t i = 0; i < n; ++i) {
      keys[i] = 0;
      for (int d = 0; d < 3; ++d) {
        const std::uint32_t c = to_int(d, xyz[3 * i + d]);
        keys[i] |= (std::uint64_t(spread_bits_3(c)) | std::uint64_t(spread_bits_3(c >> 10)) << 30) << d;
      }
      order[i] = static_cast<std::uint32_t>(i);
    }
    nodes_.push_back(Node{0, 0});
    root_is_leaf_ = !should_split(static_cast<std::uint32_t>(n), 0);
    if (root_is_leaf_) {
      nodes_[0] = Node{static_cast<std::uint32_t>(n), 0};
    } else {
      const Partition parts{keys, key_scratch, order.data(), scratch, order.data()};
      build_children(0, parts, 0, static_cast<std::uint32_t>(n), 0, count_children(keys, n, 0));
    }
    nodes_.shrink_to_fit();
    indices_ = std::move(order);
    points_ = point_block_.as<T>(0, 3 * n);  // the keys are dead from here
    for (std::size_t i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) points_[d * n + i] = T(xyz[3 * indices_[i] + d] - origin_[d]);
    }
  }

  /// Returns the k nearest points within sq(max distance) limit_sq_m2 (m^2; infinity for plain k-NN),
  /// into buffers.best, nearest first. Float trees return a superset (see collector.hpp).
  void knn(const double* query, int k, double limit_sq_m2, Buffers& buffers) const {
    knn_batch(query, 1, k, limit_sq_m2, buffers, [](std::size_t, const std::vector<Neighbour<T>>&) {});
  }

  /// For each of n queries (x,y,z triples, metres) calls emit(i, buffers.best) with what knn() returns.
  /// Returns how many queries fell in the previous query's leaf.
  template <class Emit>
  std::size_t knn_batch(const double* xyz, std::size_t n, int k, double limit_sq_m2, Buffers& buffers,
                        Emit&& emit) const {
    return knn_batch_bounded(xyz, n, k, [limit_sq_m2](std::size_t) { return limit_sq_m2; }, buffers, emit);
  }

  /// knn_batch with a limit per query: limit_sq_m2_of(i) (m^2) for query i. Returns how many queries
  /// fell in the previous query's leaf.
  template <class Limits, class Emit>
  std::size_t knn_batch_bounded(const double* xyz, std::size_t n, int k, Limits&& limit_sq_m2_of, Buffers& buffers,
                                Emit&& emit) const {
    OwnPath own;  // each query's path starts from the previous one's (see follow_own_path)
    std::size_t same_leaf = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Query q = make_query(xyz + 3 * i);
      same_leaf += follow_own_path(q, own) ? 1 : 0;
      knn_one(q, own, k, limit_sq_m2_of(i), buffers);
      emit(i, buffers.best);
    }
    return same_leaf;
  }

  /// Returns every point within sq(radius) limit_sq_m2 (m^2) in buffers.best, in tree order
  /// (float trees: a superset, see collector.hpp).
  void radius(const double* query, double limit_sq_m2, Buffers& buffers) const {
    buffers.best.clear();
    if (n_ == 0) return;
    const Query q = make_query(query);
    RadiusCollector<T> all(buffers, search_limit(limit_sq_m2, q.error));
    OwnPath own;
    follow_own_path(q, own);
    search(q, own, all);
  }

  /// Returns the nodes (node 0 is the root; a leaf root when root_is_leaf()).
  const std::vector<Node>& nodes() const { return nodes_; }
  bool root_is_leaf() const { return root_is_leaf_; }
  /// Returns the model indices of the leaf points, in tree order.
  const std::vector<std::uint32_t, DefaultInit<std::uint32_t>>& indices() const { return indices_; }
  /// Returns coordinate d of leaf entry i (T, relative to origin()). The copies are kept in tree order
  /// as three arrays (all x, all y, all z), for vectorised leaf scans.
  T coord(std::size_t i, int d) const { return points_[std::size_t(d) * n_ + i]; }
  /// Returns the origin (metres) that stored coordinates are relative to (zero for double).
  const std::array<double, 3>& origin() const { return origin_; }
  /// Returns the lowest corner of the root cube (metres).
  const std::array<double, 3>& cube_lo() const { return cube_lo_; }
  /// Returns the side of the root cube (metres).
  double side_m() const { return side_m_; }
  /// Returns the integer octree coordinate (0 .. 2^kMaxLevel - 1) of coordinate x (metres) on axis d.
  std::uint32_t to_int(int d, double x) const {
    const double t = (x - cube_lo_[d]) * scale_;
    if (!(t > 0)) return 0;
    if (t >= double((1u << kMaxLevel) - 1)) return (1u << kMaxLevel) - 1;
    return static_cast<std::uint32_t>(t);  // truncation is the floor here (t > 0), without a libm call
  }
  /// Returns bytes of the nodes.
  std::size_t node_bytes() const { return nodes_.size() * sizeof(Node); }
  /// Returns bytes of the leaf index array.
  std::size_t index_bytes() const { return indices_.size() * sizeof(std::uint32_t); }
  /// Returns bytes of the point copies kept in tree order.
  std::size_t point_copy_bytes() const { return 3 * n_ * sizeof(T); }

 private:
  struct Query {
    std::array<double, 3> q;  ///< metres, as given
    std::array<T, 3> p;       ///< relative to origin_, in T
    std::array<std::uint32_t, 3> cell;
    ErrorModel<T> error;
  };

  // The integer box of the current search ball, updated when the bound shrinks.
  struct Box {
    std::array<std::uint32_t, 3> lo, hi;
    double bound = -1;  // the bound (m^2, as T) the box was computed for
    std::uint64_t ball_units2 = 0;  // the same bound in squared integer units, rounded up
  };

  bool should_split(std::uint32_t count, int level) const {
    if (count <= max_points_ || level >= kMaxLevel) return false;
    return side_m_ / double(1u << (level + 1)) >= min_cell_m_;
  }

  // The points being sorted into cells: their Morton keys and model indices, side by side, and room for
  // one pass's output of each. A level reads one pair and writes the other, and the next level the other
  // way round (no copy back); a leaf's indices are copied to `leaves` when they are not already there.
  struct Partition {
    std::uint64_t* keys;
    std::uint64_t* key_scratch;
    std::uint32_t* order;
    std::uint32_t* scratch;
    std::uint32_t* leaves;
    Partition swapped() const { return Partition{key_scratch, keys, scratch, order, leaves}; }
  };

  // Which child of a cell at `level` a key falls in.
  static unsigned child_of(std::uint64_t key, int level) {
    return static_cast<unsigned>(key >> (3 * (kMaxLevel - level - 1))) & 7u;
  }

  // How many of the n keys fall in each child of a cell at `level`.
  static std::array<std::uint32_t, 8> count_children(const std::uint64_t* keys, std::size_t n, int level) {
    std::array<std::uint32_t, 8> counts{};
    for (std::size_t i = 0; i < n; ++i) ++counts[child_of(keys[i], level)];
    return counts;
  }

  // Fills the children of the inner node `self` (cell at `level`) from points [begin, end), of which
  // counts[j] fall in child j. The pass that moves the points to their children also counts them into
  // their grandchildren: the children's own counts, without another pass over their keys.
  void build_children(std::size_t self, const Partition& parts, std::uint32_t begin, std::uint32_t end, int level,
                      const std::array<std::uint32_t, 8>& counts) {
    std::array<std::uint32_t, 9> start{};
    for (int j = 0; j < 8; ++j) start[j + 1] = start[j] + counts[j];
    std::array<std::uint32_t, 8> next;
    for (int j = 0; j < 8; ++j) next[j] = begin + start[j];
    std::array<std::array<std::uint32_t, 8>, 8> grandchildren{};
    const int below = std::min(level + 1, kMaxLevel - 1);  // a child at the deepest level is a leaf anyway
    // Scans are coherent: points come in runs of one child, moved with the write position in a register.
    for (std::uint32_t i = begin; i < end;) {
      const unsigned j = child_of(parts.keys[i], level);
      std::uint32_t to = next[j];
      std::array<std::uint32_t, 8>& grand = grandchildren[j];
      do {
        const std::uint64_t key = parts.keys[i];
        ++grand[child_of(key, below)];
        parts.key_scratch[to] = key;
        parts.scratch[to] = parts.order[i];
        ++to;
        ++i;
      } while (i < end && child_of(parts.keys[i], level) == j);
      next[j] = to;
    }

    unsigned valid = 0, leaves = 0;
    for (int j = 0; j < 8; ++j) {
      const std::uint32_t count = start[j + 1] - start[j];
      if (count == 0) continue;
      valid |= 1u << j;
      if (!should_split(count, level + 1)) leaves |= 1u << j;
    }
    const std::size_t first = nodes_.size();
    if (first + 8 >= (std::size_t(1) << 32)) throw std::length_error("ours::Octree: too many nodes");
    nodes_.resize(first + static_cast<std::size_t>(popcount8(valid)));
    nodes_[self] = Node{valid | (leaves << 8), static_cast<std::uint32_t>(first)};
    std::size_t slot = first;
    for (int j = 0; j < 8; ++j) {
      if (!(valid & (1u << j))) continue;
      const std::uint32_t cb = begin + start[j], ce = begin + start[j + 1];
      if (leaves & (1u << j)) {
        nodes_[slot] = Node{ce - cb, cb};
        if (parts.scratch != parts.leaves) std::copy(parts.scratch + cb, parts.scratch + ce, parts.leaves + cb);
      } else {
        build_children(slot, parts.swapped(), cb, ce, level + 1, grandchildren[j]);
      }
      ++slot;
    }
  }

  Query make_query(const double* query) const {
    Query q;
    double m = 0;
    for (int d = 0; d < 3; ++d) {
      q.q[d] = query[d];
      const double rel = query[d] - origin_[d];
      q.p[d] = T(rel);
      m = std::max(m, std::abs(rel));
      q.cell[d] = to_int(d, query[d]);
    }
    q.error.abs_m2 = T(std::min(m * m, 1e30));
    return q;
  }

  // The ball of every point whose distance (in T) could be <= bound, in squared integer units rounded
  // up: conservative by the float slack.
  void update_ball(const Query& q, T bound, Box& box) const {
    box.bound = double(bound);
    const double b = double(bound) + double(q.error.slack(bound));
    const double units2 = b * scale_ * scale_;
    box.ball_units2 = !(units2 < 1e18) ? std::numeric_limits<std::uint64_t>::max()
                                       : static_cast<std::uint64_t>(std::ceil(units2 * (1 + 1e-9))) + 1;
  }

  // The ball and its integer box, as the query's cell +- the radius in whole units: to_int(q +- r) lies
  // within cell +- (floor(r * scale) + 2) (one unit for each floor, one for the rounding of q - lo, with
  // q's own rounding in r), and clamping only moves the cell towards the cube, so the box holds every
  // point of the ball.
  void update_box(const Query& q, T bound, Box& box) const {
    update_ball(q, bound, box);
    constexpr std::uint32_t kTop = (1u << kMaxLevel) - 1;
    const double b = double(bound) + double(q.error.slack(bound));
    const double magnitude = std::max({std::abs(q.q[0]), std::abs(q.q[1]), std::abs(q.q[2])});
    const double units = (std::sqrt(b) * (1 + 1e-12) + 4 * std::numeric_limits<double>::epsilon() * magnitude) * scale_;
    if (!(units < double(kTop))) {
      box.lo = {0, 0, 0};
      box.hi = {kTop, kTop, kTop};
      return;
    }
    const std::uint32_t reach = static_cast<std::uint32_t>(units) + 3;
    for (int d = 0; d < 3; ++d) {
      box.lo[d] = q.cell[d] > reach ? q.cell[d] - reach : 0;
      box.hi[d] = std::min(q.cell[d] + reach, kTop);
    }
  }

  // What the descent to a query's own leaf found: no leaf (its cell is empty, or the tree is).
  static constexpr std::uint32_t kNoLeaf = std::numeric_limits<std::uint32_t>::max();

  // The path from the root towards the cell of a query's integer coordinate: inner nodes node[0..depth]
  // (node[l] at level l), and the leaf below node[depth] holding that cell, or kNoLeaf when it is empty.
  struct OwnPath {
    std::array<std::uint32_t, kMaxLevel + 1> node;
    int depth = -1;  ///< -1: no path yet
    std::uint32_t leaf = kNoLeaf;
    std::array<std::uint32_t, 3> cell{};  ///< the integer coordinate it leads to
  };

  void knn_one(const Query& q, const OwnPath& own, int k, double limit_sq_m2, Buffers& buffers) const {
    if (n_ == 0 || k < 1) {
      buffers.best.clear();
      buffers.extras.clear();
      return;
    }
    collect_knn(k, limit_sq_m2, q.error, buffers, [&](auto& collect) { search(q, own, collect); });
  }

  // Moves own, the path of the previous query (or none), to the path of q, by integer bits alone
  // (Algorithm 1's "fast indexing"). The levels where both coordinates pick the same octants are kept
  // and the descent resumes below them: queries in scan order mostly keep the whole path. Returns
  // whether the path is the previous one down to its end (the same leaf).
  bool follow_own_path(const Query& q, OwnPath& own) const {
    if (n_ == 0 || root_is_leaf_) {
      own = OwnPath{};
      return true;
    }
    int level = 0;
    std::uint32_t index = 0;
    if (own.depth >= 0) {
      std::uint32_t differ = 0;
      for (int d = 0; d < 3; ++d) differ |= q.cell[d] ^ own.cell[d];
      const int same_levels = differ == 0 ? kMaxLevel : kMaxLevel - (32 - __builtin_clz(differ));
      own.cell = q.cell;
      if (same_levels > own.depth) return true;  // the same octants down to the last step
      level = same_levels;
      index = own.node[level];
    }
    own.cell = q.cell;
    own.leaf = kNoLeaf;
    for (; level < kMaxLevel; ++level) {
      const int shift = kMaxLevel - level - 1;
      const Node node = nodes_[index];
      const unsigned octant = ((q.cell[0] >> shift) & 1u) | (((q.cell[1] >> shift) & 1u) << 1) |
                              (((q.cell[2] >> shift) & 1u) << 2);
      own.node[level] = index;
      own.depth = level;
      if (!((node.valid() >> octant) & 1u)) break;
      index = node.first + popcount8(node.valid() & ((1u << octant) - 1));
      if ((node.leaves() >> octant) & 1u) {
        own.leaf = index;
        break;
      }
    }
    return false;
  }

  // Algorithm 1 after a look at the query's own leaf: that leaf usually brings the bound, and with it
  // the box, far below the limit. The deepest node containing the box is on the own path (the box holds
  // the query), so it is read off the path instead of descended to again.
  template <class Collect>
  void search(const Query& q, const OwnPath& own, Collect& collect) const {
    if (root_is_leaf_) {
      scan_leaf(nodes_[0], q, collect);
      return;
    }
    if (own.leaf != kNoLeaf) scan_leaf(nodes_[own.leaf], q, collect);
    Box box;
    update_box(q, collect.bound(), box);
    std::uint32_t differ = 0;
    for (int d = 0; d < 3; ++d) differ |= box.lo[d] ^ box.hi[d];
    const int common = differ == 0 ? kMaxLevel : kMaxLevel - (32 - __builtin_clz(differ));
    // Deeper than the path: the box lies inside the own leaf (scanned) or an empty cell.
    if (common > own.depth) return;
    const std::uint32_t keep = ~((std::uint32_t(1) << (kMaxLevel - common)) - 1);
    const std::array<std::uint32_t, 3> base{q.cell[0] & keep, q.cell[1] & keep, q.cell[2] & keep};
    search_node(own.node[common], common, base, q, box, own.leaf, collect);
  }

  // Algorithm 2, exact, with the paper's 96 traversal orders. Per axis, a child lies in the query's
  // half (the near side) or in the other (the far side); its squared distance, in integer units, is the
  // sum over axes of near or far parts, so with the three axes sorted by how much the far side adds
  // (delta), the order  none, a, b, {c, ab}, ac, bc, abc  of far axes is nearest first: one of
  // 8 x 6 x 2 sequences, chosen with three comparisons. Each gap is a lower bound (the gap in units
  // minus 2: one for the floor of the mapping, one for its rounding; also right for a query clamped
  // onto the root cube), and the first child beyond the current ball ends the node.
  template <class Collect>
  void search_node(std::uint32_t index, int level, const std::array<std::uint32_t, 3>& base, const Query& q, Box& box,
                   std::uint32_t scanned, Collect& collect) const {
    const Node node = nodes_[index];
    const std::uint32_t half = 1u << (kMaxLevel - level - 1);
    auto lower_bound2 = [](std::uint32_t gap) {
      const std::uint64_t g = gap > 2 ? gap - 2 : 0;
      return g * g;
    };
    unsigned near_octant = 0;
    std::uint64_t near_sum = 0;
    std::array<std::uint64_t, 3> delta;
    for (int d = 0; d < 3; ++d) {
      const std::uint32_t c = q.cell[d], mid = base[d] + half;
      const bool upper = c >= mid;
      // Gap to the query's own half of the cell (0 inside it), and to the other half.
      const std::uint32_t own_lo = upper ? mid : base[d], own_hi = own_lo + (half - 1);
      const std::uint32_t near_gap = c < own_lo ? own_lo - c : (c > own_hi ? c - own_hi : 0);
      const std::uint32_t far_gap = upper ? c - (mid - 1) : mid - c;
      const std::uint64_t near2 = lower_bound2(near_gap);
      near_octant |= unsigned(upper) << d;
      near_sum += near2;
      delta[d] = lower_bound2(far_gap) - near2;
    }
    // Sort the axes by delta (a <= b <= c), then look up the order of the children.
    std::array<std::uint8_t, 3> axis{0, 1, 2};
    if (delta[axis[1]] < delta[axis[0]]) std::swap(axis[0], axis[1]);
    if (delta[axis[2]] < delta[axis[1]]) std::swap(axis[1], axis[2]);
    if (delta[axis[1]] < delta[axis[0]]) std::swap(axis[0], axis[1]);
    const unsigned a = 1u << axis[0], b = 1u << axis[1], c = 1u << axis[2];
    const bool c_first = delta[axis[2]] <= delta[axis[0]] + delta[axis[1]];
    const std::array<unsigned, 8> far_axes{0u, a, b, c_first ? c : a | b, c_first ? a | b : c, a | c, b | c, 7u};
    const unsigned valid = node.valid();
    for (const unsigned far : far_axes) {
      const unsigned j = near_octant ^ far;
      if (!(valid & (1u << j))) continue;
      std::uint64_t dist = near_sum;
      for (int d = 0; d < 3; ++d) dist += (far >> d) & 1u ? delta[d] : 0;
      if (dist > box.ball_units2) return;
      const std::uint32_t child = node.first + popcount8(valid & ((1u << j) - 1));
      if (node.leaves() & (1u << j)) {
        if (child == scanned) continue;
        scan_leaf(nodes_[child], q, collect);
        if (double(collect.bound()) < box.bound) update_ball(q, collect.bound(), box);
      } else {
        std::array<std::uint32_t, 3> child_base;
        for (int d = 0; d < 3; ++d) child_base[d] = base[d] + (((j >> d) & 1u) ? half : 0);
        search_node(child, level + 1, child_base, q, box, scanned, collect);
      }
    }
  }

  template <class Collect>
  void scan_leaf(const Node& leaf, const Query& q, Collect& collect) const {
    const T* xs = points_;
    scan_points(xs, xs + n_, xs + 2 * n_, indices_.data(), leaf.first, leaf.first + leaf.word, q.p, collect);
  }

  template <typename U>
  using Scratch = std::vector<U, DefaultInit<U>>;  // filled once, never zeroed first

  std::vector<Node> nodes_;
  ReusableBlock point_block_;
  T* points_ = nullptr;  ///< in point_block_: all x, then all y, then all z
  Scratch<std::uint32_t> indices_;
  std::array<double, 3> origin_{0, 0, 0};
  std::array<double, 3> cube_lo_{0, 0, 0};
  double side_m_ = 1;
  double scale_ = 1;
  std::size_t n_ = 0;
  std::uint32_t max_points_ = 8;
  double min_cell_m_ = 0;
  bool root_is_leaf_ = false;
};

}  // namespace ours
