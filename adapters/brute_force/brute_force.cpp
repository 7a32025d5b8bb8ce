// Brute force: every query against every model point, in double precision. The reference that every
// other adapter is checked against, so it favours obviousness over speed.
#include "nnb/registry.hpp"

#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using Candidate = std::pair<double, PointIndex>;  // (squared distance m^2, index): ties go to the lower index

class BruteForce final : public SearchIndex {
 public:
  explicit BruteForce(const Params& params) : SearchIndex(describe(params)) {}

  std::size_t index_bytes() const override { return 0; }  // it keeps only a reference to the model

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "brute_force";
    info.concurrency = Concurrency::queries;
    info.library = "brute force (this project)";
    info.version = "1";
    info.structure = "linear scan";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    info.params = ParamReader(info.name, params).finish();
    return info;
  }

  void do_build(const Cloud& model) override { model_ = &model; }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    k_nearest_within(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    k_nearest_within(queries, k, max_dist_m * max_dist_m, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const double limit_sq = radius_m * radius_m;
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      for (Eigen::Index i = 0; i < model_->cols(); ++i) {
        const double sq = sq_dist_m2(query, model_->col(i).data());
        if (sq <= limit_sq) out.push(static_cast<PointIndex>(i), sq);
      }
      out.end_query();
    }
  }

  // A max-heap of the best k candidates so far; the limit is inclusive.
  void k_nearest_within(const Cloud& queries, int k, double limit_sq_m2, Neighbours& out) const {
    const auto keep = static_cast<std::size_t>(k);
    out.reset(static_cast<std::size_t>(queries.cols()));
    std::vector<Candidate> heap;
    heap.reserve(keep + 1);
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      heap.clear();
      for (Eigen::Index i = 0; i < model_->cols(); ++i) {
        const Candidate c{sq_dist_m2(query, model_->col(i).data()), static_cast<PointIndex>(i)};
        if (c.first > limit_sq_m2) continue;
        if (heap.size() < keep) {
          heap.push_back(c);
          std::push_heap(heap.begin(), heap.end());
        } else if (c < heap.front()) {
          std::pop_heap(heap.begin(), heap.end());
          heap.back() = c;
          std::push_heap(heap.begin(), heap.end());
        }
      }
      std::sort_heap(heap.begin(), heap.end());
      for (const auto& [sq, index] : heap) out.push(index, sq);
      out.end_query();
    }
  }

  const Cloud* model_ = nullptr;
};

}  // namespace

std::unique_ptr<SearchIndex> make_brute_force(const Params& params) { return std::make_unique<BruteForce>(params); }

}  // namespace nnb::adapters
