// OpenCV's FLANN module (cv::flann::Index, the API OpenCV users call): the copy of FLANN 1.6.10 that OpenCV
// carries, a randomized k-d tree (KDTreeIndexParams) in float with squared L2 distances. One tree and
// unlimited checks are its documented exact setting (getExactNeighbors), but that search is not exact: it
// bounds a far child by the parent's bound plus the squared offset to the node's plane, adding an axis again
// at every split on it (FLANN's comment calls that unlikely); in 3D every axis is split many times, so the
// bound grows past the true distance and points that count are pruned. Declared approximate.
// Its radiusSearch takes a squared radius, keeps d^2 <= r^2 in a std::set of every point within it and
// copies the maxResults nearest: a ranged search that visits the whole ball (native_unpruned).
// Float is made exact as for FLANN (float_libs/): coordinates relative to the model's box centre, limits
// widened, k+1 asked for with a radius fallback on near ties, distances recomputed in double.
#include <opencv2/core.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/flann/config.h>

#include "../float_libs/exact_knn.hpp"
#include "../float_libs/float_frame.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

class OpenCvFlann final : public SearchIndex {
 public:
  explicit OpenCvFlann(const Params& params) : SearchIndex(describe(params)) {}

  // An estimate (the index is opaque): the clone of the float points the index keeps, a node of 24 bytes
  // (split dimension, split value, two child pointers) for each of the 2n - 1 nodes of a tree with one point
  // a leaf, and the tree's permutation (one int a point); besides, our float copy it was built from.
  std::size_t index_bytes() const override {
    if (!index_) return 0;
    constexpr std::size_t kNodeBytes = 24;
    const std::size_t n = model_size();
    return 2 * points_.size() * sizeof(float) + (2 * n - 1) * kNodeBytes + n * sizeof(int);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "opencv_flann";
    info.library = "OpenCV";
    info.version = std::string(CV_VERSION) + " (FLANN " + FLANN_VERSION_ + ")";
    info.structure = "randomized k-d tree (one tree)";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native_unpruned;
    info.exact = false;
    ParamReader reader(info.name, params);
    info.params = reader.finish();
    info.notes =
        "cv::flann::Index with KDTreeIndexParams(1) and SearchParams(checks = unlimited), its exact setting, "
        "yet approximate (the bound adds a split axis's offset again at every split on it); float: "
        "coordinates relative to the model's bounding-box centre, limits widened by 1e-5 + 1e-6 of the "
        "coordinates, distances recomputed in double and cut at <= r; k-NN and ranged ask k+1 and, when the "
        "(k+1)-th is within float error of the k-th, add a radius search; ranged = radiusSearch with maxResults "
        "(every point within the radius collected, the nearest copied); the tree's random split axes seeded "
        "before each build; one thread (OpenCV documents no concurrent search); index_bytes estimated";
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
    // Each split axis is drawn with rand() among the widest; a fixed seed builds the same tree every time.
    cvflann::seed_random(1);
    const cv::Mat features(static_cast<int>(n), 3, CV_32F, points_.data());
    index_ = std::make_unique<cv::flann::Index>(features, cv::flann::KDTreeIndexParams(1), cvflann::FLANN_DIST_L2);
  }

  static cv::flann::SearchParams exact_params() { return cv::flann::SearchParams(cvflann::FLANN_CHECKS_UNLIMITED, 0.0f, true); }

  // The query in the frame, written into one row kept between queries rather than a Mat made for each.
  const cv::Mat& query_row(const double* query) const {
    for (int d = 0; d < 3; ++d) query_.at<float>(0, d) = frame_.coord(query, d);
    return query_;
  }

  // radiusSearch for the nearest max_results within search_m (metres) of query; indices and sq_dists sized
  // max_results, of which the returned count (or max_results, if fewer) are filled.
  int radius_search(const double* query, double search_m, int max_results, cv::Mat& indices, cv::Mat& sq_dists) const {
    return index_->radiusSearch(query_row(query), indices, sq_dists, search_m * search_m, max_results, exact_params());
  }

  // Every point within search_m (metres) of query in OpenCV's float distance, into row.
  void radius_candidates(const double* query, double search_m, std::vector<PointIndex>& row) const {
    row.clear();
    const int found = radius_search(query, search_m, capacity_, indices_, sq_dists_);
    if (found > capacity_) {
      capacity_ = found;
      radius_search(query, search_m, capacity_, indices_, sq_dists_);
    }
    for (int j = 0; j < found; ++j) row.push_back(static_cast<PointIndex>(indices_.at<int>(0, j)));
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<int>(queries.cols());
    const auto asked = static_cast<int>(float_knn_candidates(static_cast<std::size_t>(k), model_size()));
    cv::Mat query_points(n_queries, 3, CV_32F);
    for (int q = 0; q < n_queries; ++q) {
      for (int d = 0; d < 3; ++d) query_points.at<float>(q, d) = frame_.coord(queries.col(q).data(), d);
    }
    cv::Mat indices;
    cv::Mat sq_dists;
    index_->knnSearch(query_points, indices, sq_dists, asked, exact_params());
    const auto knn_row = [&](std::size_t q, std::size_t n, FloatCandidates& row) {
      row.indices.clear();
      row.sq_dists_m2.clear();
      for (int j = 0; j < static_cast<int>(n); ++j) {
        const int index = indices.at<int>(static_cast<int>(q), j);
        if (index < 0 || static_cast<std::size_t>(index) >= model_size()) continue;  // nothing found there
        row.indices.push_back(static_cast<PointIndex>(index));
        row.sq_dists_m2.push_back(sq_dists.at<float>(static_cast<int>(q), j));
      }
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      radius_candidates(queries.col(static_cast<Eigen::Index>(q)).data(), search_m, row);
    };
    exact_knn(*model_, queries, static_cast<std::size_t>(k), frame_, knn_row, radius_row, out);
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
    const auto ranged_row = [&](std::size_t q, std::size_t n, double search_m, FloatCandidates& row) {
      const int found = radius_search(queries.col(static_cast<Eigen::Index>(q)).data(), search_m,
                                      static_cast<int>(n), indices_, sq_dists_);
      const int filled = std::min(found, static_cast<int>(n));
      row.indices.clear();
      row.sq_dists_m2.clear();
      for (int j = 0; j < filled; ++j) {
        row.indices.push_back(static_cast<PointIndex>(indices_.at<int>(0, j)));
        row.sq_dists_m2.push_back(sq_dists_.at<float>(0, j));
      }
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      radius_candidates(queries.col(static_cast<Eigen::Index>(q)).data(), search_m, row);
    };
    exact_ranged(*model_, queries, static_cast<std::size_t>(k), max_dist_m, frame_, ranged_row, radius_row, out);
  }

  FloatFrame frame_;
  std::vector<float> points_;  // the model in float, row-major, relative to the frame's origin
  const Cloud* model_ = nullptr;
  std::unique_ptr<cv::flann::Index> index_;
  // radiusSearch's query and outputs, kept between queries (one thread) so that each call reuses them, and
  // how many results the outputs hold: grown to the largest count a radius search has returned.
  mutable cv::Mat query_ = cv::Mat(1, 3, CV_32F);
  mutable cv::Mat indices_;
  mutable cv::Mat sq_dists_;
  mutable int capacity_ = 64;
};

}  // namespace

std::unique_ptr<SearchIndex> make_opencv_flann(const Params& params) { return std::make_unique<OpenCvFlann>(params); }

}  // namespace nnb::adapters
