// ALGLIB's k-d tree (alglib::kdtree, nearest neighbours subpackage): a midpoint-split tree (sliding when a
// side would be empty) over a copy of the points, with leaves of at most 8 points, a number the library fixes.
// Its k-NN and radius searches are its own; it has no ranged search (via k-NN by default, or via radius).
//
// It compares squared distances, summed as brute force sums them, but keeps the squared distance from the
// query to the current cell incrementally (subtracting an axis's old term and adding its new one), so a cell
// may come out a few ulps too far: radii are widened past that, and the rows cut at <= r on distances
// recomputed from the model. The thread-safe calls take a request buffer of O(points) each; a pool keeps one
// per thread across batches, as a program querying from threads would.
#include <alglibmisc.h>

#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

// ALGLIB reports its own failed checks as alglib::ap_error, which is no std::exception.
template <class Call>
auto checked(Call&& call) {
  try {
    return call();
  } catch (const alglib::ap_error& error) {
    throw std::runtime_error("ALGLIB: " + error.msg);
  }
}

// A radius at least limit_m that the tree's rounded cell distances cannot prune a point within limit_m by,
// and whose square is neither infinite nor 0 (a squared radius of 0 means no limit to it: every point).
double widened_radius_m(double limit_m, const double* query) {
  static const double kSmallestSquarable_m = std::sqrt(DBL_MIN);
  const double scale = std::max({std::abs(query[0]), std::abs(query[1]), std::abs(query[2]), limit_m});
  const double padded_m = next_up(limit_m + 1e-12 * scale);
  return std::clamp(padded_m, kSmallestSquarable_m, std::sqrt(DBL_MAX));
}

class AlglibKdTreeIndex final : public SearchIndex {
 public:
  explicit AlglibKdTreeIndex(const Params& params) : SearchIndex(describe(params)) {}

  // What the tree holds: its copy of the points (each row twice, as searched and as returned), the tags, the
  // nodes and split values, its box and its own request buffer; and the pool's buffers.
  std::size_t index_bytes() const override {
    if (model_ == nullptr) return 0;
    const alglib_impl::kdtree& t = *tree_.c_ptr();
    const auto doubles =
        static_cast<std::size_t>(t.xy.rows * t.xy.stride + t.boxmin.cnt + t.boxmax.cnt + t.splits.cnt);
    const auto ints = static_cast<std::size_t>(t.tags.cnt + t.nodes.cnt);
    return doubles * sizeof(double) + ints * sizeof(alglib::ae_int_t) + (1 + pool_size()) * buffer_bytes();
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "alglib_kdtree";
    info.library = "ALGLIB";
    info.version = NNB_ALGLIB_VERSION;
    info.structure = "k-d tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    info.concurrency = Concurrency::queries;  // the thread-safe calls, one request buffer a thread
    info.params = ParamReader(info.name, params).finish();
    info.notes =
        "leaves of at most 8 points (fixed by the library); radii handed to it widened by 1e-12 of max(|query|, r) "
        "and one ulp, and at least sqrt(DBL_MIN) (a squared radius of 0 returns every point); rows cut at <= r "
        "on distances recomputed from the model; the thread-safe calls with one request buffer a thread, kept "
        "across batches";
    return info;
  }

  void do_build(const Cloud& model) override {
    const auto n = static_cast<alglib::ae_int_t>(model.cols());
    alglib::real_2d_array xy;
    xy.setlength(n, 3);
    alglib::integer_1d_array tags;
    tags.setlength(n);
    for (alglib::ae_int_t i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) xy[i][d] = model(d, static_cast<Eigen::Index>(i));
      tags[i] = i;
    }
    checked([&] { alglib::kdtreebuildtagged(xy, tags, n, 3, 0, /*normtype Euclidean*/ 2, tree_); });
    model_ = &model;
    std::lock_guard<std::mutex> lock(pool_mutex_);
    pool_.clear();  // buffers belong to the tree they were made for
  }

  // A request buffer for one batch (or slice of one), returned to the pool when the batch ends.
  class Lease {
   public:
    explicit Lease(const AlglibKdTreeIndex& index) : index_(index) {
      std::lock_guard<std::mutex> lock(index_.pool_mutex_);
      if (!index_.pool_.empty()) {
        buffer_ = std::move(index_.pool_.back());
        index_.pool_.pop_back();
      }
      if (!buffer_) {
        buffer_ = std::make_unique<alglib::kdtreerequestbuffer>();
        checked([&] { alglib::kdtreecreaterequestbuffer(index_.tree_, *buffer_); });
      }
    }
    ~Lease() {
      std::lock_guard<std::mutex> lock(index_.pool_mutex_);
      index_.pool_.push_back(std::move(buffer_));
    }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    const alglib::kdtreerequestbuffer& buffer() const { return *buffer_; }

   private:
    const AlglibKdTreeIndex& index_;
    std::unique_ptr<alglib::kdtreerequestbuffer> buffer_;
  };

  std::size_t pool_size() const {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    return pool_.size();
  }

  // One request buffer: the found points' indices and squared distances, and a scratch row, of the model's
  // size each (kdtreecreaterequestbuffer).
  std::size_t buffer_bytes() const {
    return model_->cols() * (2 * sizeof(double) + sizeof(alglib::ae_int_t)) + 5 * 3 * sizeof(double);
  }

  // Appends the found points of the last query on lease, those within limit_sq_m2, their distances
  // recomputed from the model; in the tree's order (k-NN: nearest first by the library's distances).
  void append_found(const Lease& lease, alglib::ae_int_t found, const double* query, double limit_sq_m2,
                    alglib::integer_1d_array& tags, Neighbours& out) const {
    if (found > 0) alglib::kdtreetsqueryresultstags(tree_, lease.buffer(), tags);
    for (alglib::ae_int_t i = 0; i < found; ++i) {
      const auto index = static_cast<PointIndex>(tags[i]);
      const double sq_m2 = sq_dist_m2(query, model_->col(static_cast<Eigen::Index>(index)).data());
      if (sq_m2 <= limit_sq_m2) out.push(index, sq_m2);
    }
    out.end_query();
  }

  // Where the library's build contracts its sums into fused multiply-adds (not Debian's x86-64 one), its
  // order may differ from the recomputed distances' in the last bits: sorts the last row again if so.
  static void keep_last_row_sorted(Neighbours& out) {
    const std::size_t begin = out.offsets[out.n_queries() - 1];
    const auto first = out.sq_dists.begin() + static_cast<std::ptrdiff_t>(begin);
    if (std::is_sorted(first, out.sq_dists.end())) return;
    std::vector<std::pair<double, PointIndex>> row;
    for (std::size_t i = begin; i < out.sq_dists.size(); ++i) row.emplace_back(out.sq_dists[i], out.indices[i]);
    std::sort(row.begin(), row.end());
    for (std::size_t i = 0; i < row.size(); ++i) {
      out.sq_dists[begin + i] = row[i].first;
      out.indices[begin + i] = row[i].second;
    }
  }

  // Appends a row for each query: the points search(buffer, x, query) found (it returns their number) within
  // limit_sq_m2; sorted again where the library's order is nearest first (keep_sorted).
  template <class Search>
  void answer_each(const Cloud& queries, double limit_sq_m2, bool keep_sorted, Search&& search,
                   Neighbours& out) const {
    const Lease lease(*this);
    alglib::real_1d_array x;
    x.setlength(3);
    alglib::integer_1d_array tags;
    checked([&] {
      for (Eigen::Index q = 0; q < queries.cols(); ++q) {
        const double* query = queries.col(q).data();
        for (int d = 0; d < 3; ++d) x[d] = query[d];
        append_found(lease, search(lease.buffer(), x, query), query, limit_sq_m2, tags, out);
        if (keep_sorted) keep_last_row_sorted(out);
      }
    });
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(queries.cols() * k));
    answer_each(queries, INFINITY, /*keep_sorted*/ true,
                [&](const alglib::kdtreerequestbuffer& buffer, const alglib::real_1d_array& x, const double*) {
                  return alglib::kdtreetsqueryknn(tree_, buffer, x, k, /*selfmatch*/ true);
                },
                out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    // Unordered (the "u" call): rows of a radius search come in the library's order.
    answer_each(queries, radius_m * radius_m, /*keep_sorted*/ false,
                [&](const alglib::kdtreerequestbuffer& buffer, const alglib::real_1d_array& x, const double* query) {
                  return alglib::kdtreetsqueryrnnu(tree_, buffer, x, widened_radius_m(radius_m, query), true);
                },
                out);
  }

  alglib::kdtree tree_;
  const Cloud* model_ = nullptr;
  mutable std::mutex pool_mutex_;
  mutable std::vector<std::unique_ptr<alglib::kdtreerequestbuffer>> pool_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_alglib_kdtree(const Params& params) {
  return std::make_unique<AlglibKdTreeIndex>(params);
}

}  // namespace nnb::adapters
