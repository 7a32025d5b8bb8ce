// CGAL: Kd_tree (sliding midpoint splitter) over point indices, the points held in a copy of the model
// as CGAL Point_3 and reached through a property map (CGAL's Search_traits_adapter), so results come
// back as indices. The heaviest header of the project: keep it in this one translation unit.
#include "nnb/registry.hpp"

#include <CGAL/Fuzzy_sphere.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/version.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;

// Readable lvalue property map: point index -> the model point as a CGAL point.
struct IndexToPoint {
  using key_type = PointIndex;
  using value_type = Point;
  using reference = const Point&;
  using category = boost::lvalue_property_map_tag;
  const std::vector<Point>* points = nullptr;
  friend reference get(const IndexToPoint& map, PointIndex index) { return (*map.points)[index]; }
};

using Traits = CGAL::Search_traits_adapter<PointIndex, IndexToPoint, CGAL::Search_traits_3<Kernel>>;
using KnnSearch = CGAL::Orthogonal_k_neighbor_search<Traits>;
using Tree = KnnSearch::Tree;
using Distance = KnnSearch::Distance;
using Sphere = CGAL::Fuzzy_sphere<Traits>;

class CgalKdTree final : public SearchIndex {
 public:
  explicit CgalKdTree(const Params& params) : SearchIndex(describe(params)) {
    bucket_size_ = static_cast<unsigned>(info().bucket->value);
  }

  // The point copy, the tree's index array and pointer array, and its nodes (a binary tree: one
  // internal node fewer than leaves).
  std::size_t index_bytes() const override {
    if (!tree_) return 0;
    const std::size_t n = points_.size();
    const auto leaves = static_cast<std::size_t>(tree_->root()->num_nodes());
    return n * (sizeof(Point) + sizeof(PointIndex) + sizeof(const PointIndex*)) +
           leaves * sizeof(Tree::Leaf_node) + (leaves - 1) * sizeof(Tree::Internal_node);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "cgal_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "CGAL";
    info.version = CGAL_VERSION_STR;
    info.structure = "k-d tree (sliding midpoint)";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    ParamReader reader(info.name, params);
    reader.get_bucket("bucket_size", 10, 1, 1 << 20, 1, 64);  // CGAL's Sliding_midpoint default
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "tree built eagerly in build() (CGAL builds on the first query otherwise); k-NN rows "
        "recomputed in double and sorted by (sq_dist, index); radius = Fuzzy_sphere (eps 0) with a "
        "slightly inflated radius, then sq_dist <= r*r";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    model_ = &model;
    points_.clear();
    points_.reserve(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) points_.emplace_back(model(0, i), model(1, i), model(2, i));
    map_.points = &points_;
    std::vector<PointIndex> indices(points_.size());
    for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = static_cast<PointIndex>(i);
    tree_ = std::make_unique<Tree>(indices.begin(), indices.end(), Tree::Splitter(bucket_size_), Traits(map_));
    tree_->build();
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const Distance distance(map_);
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(k) * queries.cols());
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const Point query(queries(0, q), queries(1, q), queries(2, q));
      const KnnSearch search(*tree_, query, static_cast<unsigned>(k), 0.0, true, distance, true);
      for (const auto& [index, sq_dist] : search) out.push(index, sq_dist);
      out.end_query();
    }
    recompute_sq_dists(*model_, queries, out);
    sort_and_truncate(static_cast<std::size_t>(k), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const Traits traits(map_);
    std::vector<PointIndex> found;
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const Point query(queries(0, q), queries(1, q), queries(2, q));
      const double scale = std::max({std::abs(query.x()), std::abs(query.y()), std::abs(query.z()), radius_m});
      found.clear();
      tree_->search(std::back_inserter(found), Sphere(query, radius_m + 1e-12 * scale, 0.0, traits));
      for (const PointIndex index : found) out.push(index, 0.0);
      out.end_query();
    }
    recompute_sq_dists(*model_, queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  unsigned bucket_size_ = 10;
  const Cloud* model_ = nullptr;
  std::vector<Point> points_;  // the property map points here: never resized after build
  IndexToPoint map_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_cgal_kdtree(const Params& params) { return std::make_unique<CgalKdTree>(params); }

}  // namespace nnb::adapters
