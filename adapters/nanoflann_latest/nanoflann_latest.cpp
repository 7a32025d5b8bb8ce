// nanoflann_latest: the newest nanoflann (a checkout given by NNB_NANOFLANN_LATEST_DIR), beside Debian's
// in the same binary. Its namespace is renamed at the include so that the two versions' templates never
// share a mangled name (one definition each, no ODR clash); this translation unit sees only this header.
// Like 1.4.3, 1.12 keeps a point only when its squared distance is strictly below the bound, so radius and
// ranged searches run with a slightly inflated bound and are filtered exactly by our inclusive rule.
#include "../nanoflann/nanoflann_source.hpp"

// Everything the header includes, first, so that the rename below touches nanoflann's own names only.
#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <future>
#include <istream>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <ostream>
#include <stack>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#define nanoflann nanoflann_latest
#include <nanoflann.hpp>
#undef nanoflann

namespace nnb::adapters {
namespace {

using nanoflann_source::CloudSource;
using nanoflann_source::append_within;
using nanoflann_source::inflated_sq_bound_m2;

namespace nf = ::nanoflann_latest;

using Metric = nf::L2_Simple_Adaptor<double, CloudSource, double, PointIndex>;
using Tree = nf::KDTreeSingleIndexAdaptor<Metric, CloudSource, 3, PointIndex>;

std::string version_text() {
  return std::to_string((NANOFLANN_VERSION >> 16) & 0xff) + "." + std::to_string((NANOFLANN_VERSION >> 8) & 0xff) +
         "." + std::to_string(NANOFLANN_VERSION & 0xff);
}

class NanoflannLatest final : public SearchIndex {
 public:
  explicit NanoflannLatest(const Params& params) : SearchIndex(describe(params)), leaf_size_(info().bucket->value) {}

  std::size_t index_bytes() const override { return tree_ ? tree_->usedMemory(*tree_) : 0; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "nanoflann_latest";
    info.concurrency = Concurrency::queries;
    info.library = "nanoflann (newest release)";
    info.version = version_text();
    info.structure = "k-d tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_bucket("leaf_size", 10, 1, 1 << 20, 1, 64);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "the release users get from nanoflann's repository, built when NNB_NANOFLANN_LATEST_DIR points at it; "
        "ranged = its native rknnSearch, radius = radiusSearch, both with a bound inflated past its strict '<' "
        "and filtered by sq_dist <= r*r; namespace renamed at the include to live beside Debian's 1.4.3";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    source_.cloud = &model;
    tree_ = std::make_unique<Tree>(3, source_, nf::KDTreeSingleIndexAdaptorParams(leaf_size_));
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    nanoflann_source::knn_rows(*tree_, queries, k, model_size(), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    std::vector<nf::ResultItem<PointIndex, double>> found;
    const nf::SearchParameters unsorted(0.0f, false);
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      found.clear();
      (void)tree_->radiusSearch(query, inflated_sq_bound_m2(radius_m, query), found, unsorted);
      for (const auto& item : found) out.push(item.first, item.second);
      out.end_query();
    }
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    const std::size_t keep = std::min<std::size_t>(static_cast<std::size_t>(k), model_size());
    std::vector<PointIndex> indices(keep);
    std::vector<double> sq_dists(keep);
    const auto n = static_cast<std::size_t>(queries.cols());
    out.reset(n, n);
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      const std::size_t found =
          tree_->rknnSearch(query, keep, indices.data(), sq_dists.data(), inflated_sq_bound_m2(max_dist_m, query));
      append_within(max_dist_m * max_dist_m, indices.data(), sq_dists.data(), found, out);
    }
  }

  int leaf_size_;
  CloudSource source_;  // the tree holds a reference to it
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_nanoflann_latest(const Params& params) {
  return std::make_unique<NanoflannLatest>(params);
}

}  // namespace nnb::adapters
