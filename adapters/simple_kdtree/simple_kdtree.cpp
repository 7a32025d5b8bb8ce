// simple_kdtree: our rebuild of 3DTK's simple k-d tree (slam6d's KDtree, not its optimised octree) from
// its published description: each node splits at the centre of its points' bounding box along the box's
// longest side, children are heap-allocated nodes linked by pointers, leaves hold at most a bucket of
// points, and the search recurses into the child on the query's side first, pruning a node when the
// ball of the current search radius misses its bounding box (the ranged search of the paper's
// Algorithms 2 and 3). Everything is double precision.
#include "nnb/best_k.hpp"
#include "nnb/box.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

constexpr int kDefaultBucketSize = 20;  // slam6D's default bucket size


struct Node {
  Box box;                          // tight bounds of the node's points
  int axis = -1;                    // split axis; -1 for a leaf
  double split = 0.0;               // points below go to low, the others to high
  std::unique_ptr<Node> low, high;  // heap-allocated children, as 3DTK's nodes are
  std::uint32_t begin = 0, end = 0; // the node's points: indices_[begin, end)
  bool is_leaf() const { return axis < 0; }
};


class SimpleKdTree final : public SearchIndex {
 public:
  explicit SimpleKdTree(const Params& params) : SearchIndex(describe(params)) {
    bucket_size_ = static_cast<std::uint32_t>(info().bucket->value);
  }

  std::size_t index_bytes() const override {
    return node_count_ * sizeof(Node) + indices_.capacity() * sizeof(PointIndex);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "simple_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "ours (this project, after 3DTK's simple k-d tree)";
    info.version = "1";
    info.structure = "k-d tree (bounding-box centre split, pointer nodes)";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_bucket("bucket_size", kDefaultBucketSize, 1, 1 << 20, 1, 64);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "3DTK's k-d tree is not packaged: rebuilt from its description (split at the centre of the points' "
        "bounding box along its longest side, heap-allocated pointer nodes, buckets of bucket_size, slam6D's "
        "default 20, recursive search pruned by each node's tight bounding box); where rounding puts the "
        "centre on the box's edge (extents of an ulp at 1e15 m) the split moves to the largest coordinate "
        "so that both sides keep points, and boxes of a single point become leaves of any size";
    return info;
  }

  void do_build(const Cloud& model) override {
    model_ = &model;
    indices_.resize(static_cast<std::size_t>(model.cols()));
    for (std::size_t i = 0; i < indices_.size(); ++i) indices_[i] = static_cast<PointIndex>(i);
    node_count_ = 0;
    root_ = build_node(0, static_cast<std::uint32_t>(indices_.size()));
  }

  const double* point(PointIndex i) const { return model_->col(static_cast<Eigen::Index>(i)).data(); }

  Box bounds_of(std::uint32_t begin, std::uint32_t end) const {
    Box box;
    const double* first = point(indices_[begin]);
    for (int a = 0; a < 3; ++a) box.lo[a] = box.hi[a] = first[a];
    for (std::uint32_t i = begin + 1; i < end; ++i) {
      const double* p = point(indices_[i]);
      for (int a = 0; a < 3; ++a) {
        box.lo[a] = std::min(box.lo[a], p[a]);
        box.hi[a] = std::max(box.hi[a], p[a]);
      }
    }
    return box;
  }

  static int longest_axis(const Box& box) {
    int axis = 0;
    for (int a = 1; a < 3; ++a) {
      if (box.hi[a] - box.lo[a] > box.hi[axis] - box.lo[axis]) axis = a;
    }
    return axis;
  }

  // Moves the points below split to the front of [begin, end); returns where the others start.
  std::uint32_t partition_below(std::uint32_t begin, std::uint32_t end, int axis, double split) {
    const auto first = indices_.begin() + begin;
    const auto middle = std::partition(first, indices_.begin() + end,
                                       [&](PointIndex i) { return point(i)[axis] < split; });
    return begin + static_cast<std::uint32_t>(middle - first);
  }

  // Every split leaves points on both sides, so the depth stays below the point count; centre splits keep it
  // near the number of halvings that separate the closest points.
  std::unique_ptr<Node> build_node(std::uint32_t begin, std::uint32_t end) {
    auto node = std::make_unique<Node>();
    ++node_count_;
    node->begin = begin;
    node->end = end;
    node->box = bounds_of(begin, end);
    const int axis = longest_axis(node->box);
    const double lo = node->box.lo[axis], hi = node->box.hi[axis];
    if (end - begin <= bucket_size_ || !(lo < hi)) return node;  // a bucket, or a single location
    double split = lo + 0.5 * (hi - lo);
    std::uint32_t middle = partition_below(begin, end, axis, split);
    if (middle == begin || middle == end) {  // the centre rounded onto an edge of the box
      split = hi;
      middle = partition_below(begin, end, axis, split);
    }
    node->axis = axis;
    node->split = split;
    node->low = build_node(begin, middle);
    node->high = build_node(middle, end);
    return node;
  }

  void search_k(const double* q, const Node& node, BestK& best) const {
    if (sq_dist_to_box_m2(q, node.box) > best.bound_sq_m2()) return;
    if (node.is_leaf()) {
      for (std::uint32_t i = node.begin; i < node.end; ++i) {
        best.offer(sq_dist_m2(q, point(indices_[i])), indices_[i]);
      }
      return;
    }
    const bool below = q[node.axis] < node.split;
    search_k(q, below ? *node.low : *node.high, best);
    search_k(q, below ? *node.high : *node.low, best);
  }

  void search_ball(const double* q, const Node& node, double limit_sq_m2, Neighbours& out) const {
    if (sq_dist_to_box_m2(q, node.box) > limit_sq_m2) return;
    if (node.is_leaf()) {
      for (std::uint32_t i = node.begin; i < node.end; ++i) {
        const double sq = sq_dist_m2(q, point(indices_[i]));
        if (sq <= limit_sq_m2) out.push(indices_[i], sq);
      }
      return;
    }
    search_ball(q, *node.low, limit_sq_m2, out);
    search_ball(q, *node.high, limit_sq_m2, out);
  }

  void k_nearest_within(const Cloud& queries, int k, double limit_sq_m2, Neighbours& out) const {
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      BestK best(static_cast<std::size_t>(k), limit_sq_m2);
      search_k(queries.col(q).data(), *root_, best);
      best.write_sorted(out);
    }
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    k_nearest_within(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    k_nearest_within(queries, k, max_dist_m * max_dist_m, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      search_ball(queries.col(q).data(), *root_, radius_m * radius_m, out);
      out.end_query();
    }
  }

  std::uint32_t bucket_size_ = kDefaultBucketSize;
  const Cloud* model_ = nullptr;
  std::vector<PointIndex> indices_;  // model indices, grouped by leaf
  std::unique_ptr<Node> root_;
  std::size_t node_count_ = 0;
};

}  // namespace

std::unique_ptr<SearchIndex> make_simple_kdtree(const Params& params) {
  return std::make_unique<SimpleKdTree>(params);
}

}  // namespace nnb::adapters
