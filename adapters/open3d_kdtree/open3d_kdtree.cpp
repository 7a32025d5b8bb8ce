// Open3D's geometry::KDTreeFlann (nanoflann inside, 15 points a leaf, double). k-NN = SearchKNN,
// radius = SearchRadius, ranged = SearchHybrid. Note that Open3D implements SearchHybrid as a k-NN
// search followed by a cut at the radius: its own ranged search, but not a pruned one (native_unpruned).
#include <open3d/Open3DConfig.h>
#include <open3d/geometry/KDTreeFlann.h>

#include "nnb/registry.hpp"

#include <algorithm>
#include <memory>
#include <vector>

namespace nnb::adapters {
namespace {

/// Radius (m) to hand Open3D so that a point with sq_dist_m2 <= radius_m^2 passes its strict d^2 < r^2 test:
/// nanoflann sums the squares in its own order (a few ulps apart), and radius 0 must still find
/// coincident points.
double search_radius_m(double radius_m) { return radius_m * (1.0 + 1e-12) + 1e-150; }

class Open3dKdTree final : public SearchIndex {
 public:
  explicit Open3dKdTree(const Params& params) : SearchIndex(describe(params)) {}

  // Open3D copies the points (24 bytes a point, unused by the search) and indexes the caller's MatrixXd,
  // which we keep (24); nanoflann keeps a permutation of Eigen::Index (8) and 40-byte nodes, about 9.4 bytes
  // a point for 15-point leaves (FLANN's figure for the same split rule and node size, measured).
  std::size_t index_bytes() const override { return model_size() * (24 + 24 + 8) + model_size() * 94 / 10; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "open3d_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "Open3D";
    info.version = OPEN3D_VERSION;
    info.structure = "k-d tree (nanoflann, 15 points a leaf)";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native_unpruned;
    info.exact = true;
    info.params = ParamReader(info.name, params).finish();  // Open3D fixes the leaf size at 15
    info.notes =
        "Open3D keeps d^2 < r^2 (drops points at r, finds nothing at r=0): radius and hybrid searched 1e-12 "
        "wider, distances recomputed in double and cut at <= r; rows re-sorted by (distance, index); "
        "SearchHybrid is k-NN then a cut inside Open3D; we keep a MatrixXd of the model because Open3D "
        "0.16.1 searches the caller's matrix, not its own copy";
    return info;
  }

  void do_build(const Cloud& model) override {
    // Open3D 0.16.1 searches the matrix it is given, not the copy it makes (tested: overwriting the caller's
    // matrix changes the answers), so ours must outlive the tree; a temporary would dangle.
    points_ = model;
    model_ = &model;
    tree_ = std::make_unique<open3d::geometry::KDTreeFlann>();
    if (!tree_->SetMatrixData(points_)) throw InputError(info().name + ": Open3D refused to build the tree");
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto kk = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(k), model_size()));
    collect(queries, out, kk, [&](const Eigen::Vector3d& query, std::vector<int>& indices, std::vector<double>& sq) {
      tree_->SearchKNN(query, kk, indices, sq);
    });
    sort_and_truncate(static_cast<std::size_t>(kk), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const double search_m = search_radius_m(radius_m);
    collect(queries, out, 0, [&](const Eigen::Vector3d& query, std::vector<int>& indices, std::vector<double>& sq) {
      tree_->SearchRadius(query, search_m, indices, sq);
    });
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const auto kk = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(k), model_size()));
    const double search_m = search_radius_m(max_dist_m);
    collect(queries, out, kk, [&](const Eigen::Vector3d& query, std::vector<int>& indices, std::vector<double>& sq) {
      tree_->SearchHybrid(query, search_m, kk, indices, sq);
    });
    filter_by_sq_dist(max_dist_m * max_dist_m, out);
    sort_and_truncate(static_cast<std::size_t>(kk), out);
  }

  // Runs search on every query and stores its indices with distances recomputed by sq_dist_m2.
  template <typename Search>
  void collect(const Cloud& queries, Neighbours& out, int per_query, Search&& search) const {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries, n_queries * static_cast<std::size_t>(per_query));
    std::vector<int> indices;
    std::vector<double> sq_dists;
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const Eigen::Vector3d query = queries.col(q);
      search(query, indices, sq_dists);
      for (const int index : indices) {
        out.push(static_cast<PointIndex>(index), sq_dist_m2(query.data(), model_->col(index).data()));
      }
      out.end_query();
    }
  }

  Eigen::MatrixXd points_;
  const Cloud* model_ = nullptr;
  std::unique_ptr<open3d::geometry::KDTreeFlann> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_open3d_kdtree(const Params& params) {
  return std::make_unique<Open3dKdTree>(params);
}

}  // namespace nnb::adapters
