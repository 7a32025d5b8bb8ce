// FLANN's exact single k-d tree (KDTreeSingleIndex) in float. FLANN has k-NN, radius search and, since
// 1.8, a native ranged search: radius search with SearchParams::max_neighbors, which keeps the k nearest
// within the radius and prunes with the k-th (the paper's 2011 FLANN lacked it and ran k-NN then a cut).
// dist.h must come first: kdtree_single_index.h uses it without including it. Including only this
// index (not flann.hpp, which instantiates every index type) saves ~10 s of compile time.
#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/config.h>

#include "../float_libs/exact_knn.hpp"
#include "../float_libs/float_frame.hpp"
#include "nnb/registry.hpp"

#include <memory>
#include <vector>

namespace nnb::adapters {
namespace {

using FlannTree = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

// FLANN's radius rule (d^2 < r^2, float), appending straight into a row of model indices.
class RadiusRow final : public flann::ResultSet<float> {
 public:
  RadiusRow(float sq_radius_m2, std::vector<PointIndex>& row) : sq_radius_m2_(sq_radius_m2), row_(row) {}
  bool full() const override { return true; }
  float worstDist() const override { return sq_radius_m2_; }
  void addPoint(float sq_dist_m2, std::size_t index) override {
    if (sq_dist_m2 < sq_radius_m2_) row_.push_back(static_cast<PointIndex>(index));
  }

 private:
  float sq_radius_m2_;
  std::vector<PointIndex>& row_;
};

class FlannKdTree final : public SearchIndex {
 public:
  explicit FlannKdTree(const Params& params) : SearchIndex(describe(params)) {
    leaf_size_ = info().bucket->value;
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
    info.concurrency = Concurrency::queries;
    info.library = "FLANN";
    info.version = FLANN_VERSION_;
    info.structure = "k-d tree";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    info.exact = true;
    ParamReader reader(info.name, params);
    reader.get_bucket("leaf_size", 10, 1, 1 << 20, 1, 64);  // the paper's choice on synthetic data (15 on real scans)
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "FLANN keeps d^2 < r^2 in float (drops points at r, finds nothing at r=0): float coordinates "
        "relative to the model's bounding-box centre, radius searched wider by 1e-5 + 1e-6 of the coordinates, "
        "distances recomputed in double and cut at <= r; k-NN asks k+1 and, when the (k+1)-th is within float error of "
        "the k-th, adds a radius search so near-ties resolve as in double; ranged = FLANN's radius search with "
        "max_neighbors = k+1 (KNNRadiusResultSet), made exact the same way; single core";
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
    const std::size_t asked = float_knn_candidates(static_cast<std::size_t>(k), model_size());
    std::vector<float> query_points(n_queries * 3);
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      for (int d = 0; d < 3; ++d) query_points[q * 3 + d] = frame_.coord(query, d);
    }
    std::vector<std::size_t> indices(n_queries * asked, static_cast<std::size_t>(-1));
    std::vector<float> sq_dists(n_queries * asked);
    flann::Matrix<std::size_t> index_matrix(indices.data(), n_queries, asked);
    flann::Matrix<float> dist_matrix(sq_dists.data(), n_queries, asked);
    tree_->knnSearch(flann::Matrix<float>(query_points.data(), n_queries, 3), index_matrix, dist_matrix, asked,
                     exact_single_core(false));
    const auto knn_row = [&](std::size_t q, std::size_t n, FloatCandidates& row) {
      row.indices.clear();
      row.sq_dists_m2.clear();
      for (std::size_t j = q * n; j < (q + 1) * n; ++j) {
        if (indices[j] >= model_size()) continue;  // FLANN leaves -1 where it found nothing
        row.indices.push_back(static_cast<PointIndex>(indices[j]));
        row.sq_dists_m2.push_back(sq_dists[j]);
      }
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      radius_candidates(queries.col(static_cast<Eigen::Index>(q)).data(), search_m, row);
    };
    exact_knn(*model_, queries, static_cast<std::size_t>(k), frame_, knn_row, radius_row, out);
  }

  /// Every point closer than search_m (metres) to query in FLANN's float distance, into row.
  void radius_candidates(const double* query, double search_m, std::vector<PointIndex>& row) const {
    const float query_f[3] = {frame_.coord(query, 0), frame_.coord(query, 1), frame_.coord(query, 2)};
    row.clear();
    RadiusRow result(static_cast<float>(search_m * search_m), row);
    tree_->findNeighbors(result, query_f, exact_single_core(false));
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    std::vector<PointIndex> row;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      radius_candidates(query, frame_.search_radius_m(query, radius_m), row);
      for (const PointIndex index : row) out.push(index, 0.0);
      out.end_query();
    }
    recompute_sq_dists(*model_, queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    std::vector<std::size_t> indices;
    const auto ranged_row = [&](std::size_t q, std::size_t n, double search_m, FloatCandidates& row) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const float query_f[3] = {frame_.coord(query, 0), frame_.coord(query, 1), frame_.coord(query, 2)};
      flann::KNNRadiusResultSet<float> result(static_cast<float>(search_m * search_m), n);
      tree_->findNeighbors(result, query_f, exact_single_core(false));
      indices.resize(result.size());
      row.sq_dists_m2.resize(result.size());
      result.copy(indices.data(), row.sq_dists_m2.data(), result.size(), false);
      row.indices.assign(indices.begin(), indices.end());
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      radius_candidates(queries.col(static_cast<Eigen::Index>(q)).data(), search_m, row);
    };
    exact_ranged(*model_, queries, static_cast<std::size_t>(k), max_dist_m, frame_, ranged_row, radius_row, out);
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
