// FLANN's exact single k-d tree (KDTreeSingleIndex) in float. FLANN has k-NN and radius search;
// ranged search is k-NN then a distance cut, as the paper ran it.
// dist.h must come first: kdtree_single_index.h uses it without including it. Including only this
// index (not flann.hpp, which instantiates every index type) saves ~10 s of compile time.
#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/config.h>

#include "../float_libs/float_frame.hpp"
#include "nnb/registry.hpp"

#include <memory>
#include <vector>

namespace nnb::adapters {
namespace {

using FlannTree = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

class FlannKdTree final : public SearchIndex {
 public:
  explicit FlannKdTree(const Params& params) : SearchIndex(describe(params)) {
    leaf_size_ = std::stoi(info().params.at("leaf_size"));
  }

  // FLANN's usedMemory() counts its node pool and its permutation (one int per point); on top of it
  // FLANN keeps a reordered float copy of the points (reorder=true), a pointer per point to the
  // dataset rows (NNIndex::points_), and it needs our float copy of the model it was built on.
  std::size_t index_bytes() const override {
    if (!tree_) return 0;
    const std::size_t n = model_size();
    return static_cast<std::size_t>(tree_->usedMemory()) + n * 3 * sizeof(float) + n * sizeof(float*) +
           points_.size() * sizeof(float);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "flann_kdtree";
    info.library = "FLANN";
    info.version = FLANN_VERSION_;
    info.structure = "k-d tree";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    info.exact = true;
    ParamReader reader(info.name, params);
    reader.get_int("leaf_size", 10, 1, 1 << 20);  // the paper's choice on synthetic data (15 on real scans)
    info.params = reader.finish();
    info.notes =
        "FLANN keeps d^2 < r^2 in float (drops points at r, finds nothing at r=0): float coordinates "
        "relative to the model's bounding-box centre, radius searched wider by 1e-5 + 1e-6 of the coordinates, "
        "distances recomputed in double and cut at <= r; k-NN rows re-sorted by double distance; single core";
    return info;
  }

  void do_build(const Cloud& model) override {
    frame_.fit(model);
    const auto n = static_cast<std::size_t>(model.cols());
    points_.resize(n * 3);
    for (std::size_t i = 0; i < n; ++i) {
      const double* point = model.col(static_cast<Eigen::Index>(i)).data();
      for (int d = 0; d < 3; ++d) points_[i * 3 + d] = frame_.coord(point, d);
    }
    model_ = &model;
    tree_ = std::make_unique<FlannTree>(flann::Matrix<float>(points_.data(), n, 3),
                                        flann::KDTreeSingleIndexParams(leaf_size_, true));
    tree_->buildIndex();
  }

  static flann::SearchParams exact_single_core(bool sorted) {
    flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED, 0.0f, sorted);
    params.cores = 1;
    return params;
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const std::size_t kk = std::min(static_cast<std::size_t>(k), model_size());
    std::vector<float> query_points(n_queries * 3);
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      for (int d = 0; d < 3; ++d) query_points[q * 3 + d] = frame_.coord(query, d);
    }
    std::vector<std::size_t> indices(n_queries * kk, static_cast<std::size_t>(-1));
    std::vector<float> sq_dists(n_queries * kk);
    flann::Matrix<std::size_t> index_matrix(indices.data(), n_queries, kk);
    flann::Matrix<float> dist_matrix(sq_dists.data(), n_queries, kk);
    tree_->knnSearch(flann::Matrix<float>(query_points.data(), n_queries, 3), index_matrix, dist_matrix, kk,
                     exact_single_core(true));
    out.reset(n_queries, n_queries * kk);
    for (std::size_t q = 0; q < n_queries; ++q) {
      for (std::size_t j = 0; j < kk; ++j) {
        const std::size_t index = indices[q * kk + j];
        if (index < model_size()) out.push(static_cast<PointIndex>(index), 0.0);
      }
      out.end_query();
    }
    // Float distances can order near-ties differently from double: recompute, then sort by (sq_dist, index).
    recompute_sq_dists(*model_, queries, out);
    sort_and_truncate(kk, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto params = exact_single_core(false);
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    std::vector<std::size_t> indices;
    std::vector<float> sq_dists;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const float query_f[3] = {frame_.coord(query, 0), frame_.coord(query, 1), frame_.coord(query, 2)};
      const double search_m = frame_.search_radius_m(query, radius_m);
      flann::RadiusResultSet<float> result(static_cast<float>(search_m * search_m));
      tree_->findNeighbors(result, query_f, params);
      indices.resize(result.size());
      sq_dists.resize(result.size());
      result.copy(indices.data(), sq_dists.data(), indices.size(), false);
      for (const std::size_t index : indices) out.push(static_cast<PointIndex>(index), 0.0);
      out.end_query();
    }
    recompute_sq_dists(*model_, queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  int leaf_size_ = 10;
  FloatFrame frame_;
  std::vector<float> points_;  // the model in float, row-major; FLANN's dataset
  const Cloud* model_ = nullptr;
  std::unique_ptr<FlannTree> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_flann_kdtree(const Params& params) {
  return std::make_unique<FlannKdTree>(params);
}

}  // namespace nnb::adapters
