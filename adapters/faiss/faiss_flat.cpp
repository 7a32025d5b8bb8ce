// FAISS's IndexFlatL2: an exhaustive scan over a float copy of the points, the library people reach for
// first. k-NN = search, radius = range_search (squared radius, strict d^2 < r^2), ranged = k-NN then a cut.
// FAISS computes each distance as a float sum of squares (fvec_L2sqr) for batches under
// distance_compute_blas_threshold (20) queries, and as |x|^2 + |y|^2 - 2 x.y through BLAS for larger ones;
// the latter loses the small distances ICP asks about to cancellation (error ~1e-7 of |x|^2, not of d^2),
// so every call here keeps the sum-of-squares path and is made exact as FLANN is (../float_libs).
#include <faiss/Index.h>
#include <faiss/IndexFlat.h>
#include <faiss/impl/AuxIndexStructures.h>
#include <faiss/utils/distances.h>
#include <omp.h>

#include "../float_libs/exact_knn.hpp"
#include "../float_libs/float_frame.hpp"
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <climits>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

using FaissIndex = faiss::Index::idx_t;

/// For its lifetime: FAISS's per-distance float path whatever the batch size, on the calling thread only.
/// Both settings are process-wide or per-thread globals of FAISS and OpenMP: restored on exit.
class ExactSingleCoreScope {
 public:
  ExactSingleCoreScope() : blas_threshold_(faiss::distance_compute_blas_threshold), threads_(omp_get_max_threads()) {
    faiss::distance_compute_blas_threshold = INT_MAX;
    omp_set_num_threads(1);
  }
  ~ExactSingleCoreScope() {
    faiss::distance_compute_blas_threshold = blas_threshold_;
    omp_set_num_threads(threads_);
  }
  ExactSingleCoreScope(const ExactSingleCoreScope&) = delete;
  ExactSingleCoreScope& operator=(const ExactSingleCoreScope&) = delete;

 private:
  int blas_threshold_;
  int threads_;
};

/// FAISS's squared radius (m^2, float) that keeps every point closer than search_m under its strict test.
float faiss_sq_radius_m2(double search_m) {
  return next_up(static_cast<float>(search_m * search_m));
}

class FaissFlat final : public SearchIndex {
 public:
  explicit FaissFlat(const Params& params) : SearchIndex(describe(params)) {}

  // IndexFlatL2 holds the float copy of the points (12 bytes a point) and nothing else.
  std::size_t index_bytes() const override { return index_ ? index_->codes.capacity() : 0; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "faiss_flat";
    info.library = "FAISS";
    info.version = std::to_string(FAISS_VERSION_MAJOR) + "." + std::to_string(FAISS_VERSION_MINOR) + "." +
                   std::to_string(FAISS_VERSION_PATCH);
    info.structure = "exhaustive scan (IndexFlatL2)";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    info.exact = true;
    info.params = ParamReader(info.name, params).finish();  // a flat index has no parameter
    info.notes =
        "FAISS keeps d^2 < r^2 in float: float coordinates relative to the model's bounding-box centre, radius "
        "searched wider by 1e-5 + 1e-6 of the coordinates, distances recomputed in double and cut at <= r; "
        "k-NN asks k+1 and adds a radius search on float near-ties; distance_compute_blas_threshold raised "
        "during each call so batches of 20+ queries keep the per-distance float path (BLAS's |x|^2+|y|^2-2xy "
        "is off by ~1e-7 of |x|^2); one OpenMP thread during each call";
    return info;
  }

  void do_build(const Cloud& model) override {
    frame_.fit(model);
    const std::vector<float> points = to_float(model);
    index_ = std::make_unique<faiss::IndexFlatL2>(3);
    index_->add(model.cols(), points.data());
    model_ = &model;
  }

  /// The columns of cloud in frame_'s float coordinates, row-major.
  std::vector<float> to_float(const Cloud& cloud) const {
    std::vector<float> out(static_cast<std::size_t>(cloud.cols()) * 3);
    for (Eigen::Index i = 0; i < cloud.cols(); ++i) {
      for (int d = 0; d < 3; ++d) out[static_cast<std::size_t>(3 * i + d)] = frame_.coord(cloud.col(i).data(), d);
    }
    return out;
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) {
      out.reset();
      return;
    }
    const std::size_t asked = float_knn_candidates(static_cast<std::size_t>(k), model_size());
    const std::vector<float> query_points = to_float(queries);
    std::vector<float> sq_dists(n_queries * asked);
    std::vector<FaissIndex> indices(n_queries * asked, -1);
    const ExactSingleCoreScope scope;
    index_->search(queries.cols(), query_points.data(), static_cast<FaissIndex>(asked), sq_dists.data(),
                   indices.data());
    const auto knn_row = [&](std::size_t q, std::size_t n, FloatCandidates& row) {
      row.indices.clear();
      row.sq_dists_m2.clear();
      for (std::size_t j = q * n; j < (q + 1) * n; ++j) {
        if (indices[j] < 0) continue;  // FAISS leaves -1 where it found nothing
        row.indices.push_back(static_cast<PointIndex>(indices[j]));
        row.sq_dists_m2.push_back(sq_dists[j]);
      }
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      faiss::RangeSearchResult found(1);
      index_->range_search(1, &query_points[3 * q], faiss_sq_radius_m2(search_m), &found);
      row.assign(found.labels, found.labels + found.lims[1]);
    };
    exact_knn(*model_, queries, static_cast<std::size_t>(k), frame_, knn_row, radius_row, out);
  }

  // range_search takes one radius per batch, and the margin for float rounding grows with a query's distance
  // from the model's centre: queries are batched by the binary order of their margin, so that no query is
  // searched more than twice its own margin wider.
  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const std::vector<float> query_points = to_float(queries);
    std::map<int, std::vector<std::size_t>> batches;
    for (std::size_t q = 0; q < n_queries; ++q) {
      batches[std::ilogb(frame_.search_radius_m(queries.col(static_cast<Eigen::Index>(q)).data(), 0.0))].push_back(q);
    }
    std::vector<std::unique_ptr<faiss::RangeSearchResult>> results;
    std::vector<std::pair<std::size_t, std::size_t>> row_of(n_queries);  // (result, row) of each query
    std::vector<float> batch_points;
    const ExactSingleCoreScope scope;
    for (const auto& [order, members] : batches) {
      double search_m = 0.0;
      batch_points.clear();
      for (std::size_t i = 0; i < members.size(); ++i) {
        const std::size_t q = members[i];
        search_m = std::max(search_m, frame_.search_radius_m(queries.col(static_cast<Eigen::Index>(q)).data(), radius_m));
        batch_points.insert(batch_points.end(), &query_points[3 * q], &query_points[3 * q] + 3);
        row_of[q] = {results.size(), i};
      }
      results.push_back(std::make_unique<faiss::RangeSearchResult>(static_cast<FaissIndex>(members.size())));
      index_->range_search(static_cast<FaissIndex>(members.size()), batch_points.data(),
                           faiss_sq_radius_m2(search_m), results.back().get());
    }
    const double limit_sq_m2 = radius_m * radius_m;
    out.reset(n_queries);
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const auto& found = *results[row_of[q].first];
      const std::size_t row = row_of[q].second;
      for (std::size_t i = found.lims[row]; i < found.lims[row + 1]; ++i) {
        const auto index = static_cast<PointIndex>(found.labels[i]);
        const double sq_m2 = sq_dist_m2(query, model_->col(index).data());
        if (sq_m2 <= limit_sq_m2) out.push(index, sq_m2);
      }
      out.end_query();
    }
  }

  FloatFrame frame_;
  const Cloud* model_ = nullptr;
  std::unique_ptr<faiss::IndexFlatL2> index_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_faiss_flat(const Params& params) {
  return std::make_unique<FaissFlat>(params);
}

}  // namespace nnb::adapters
