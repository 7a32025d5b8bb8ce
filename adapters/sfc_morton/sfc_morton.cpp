// sfc_morton: our rebuild of STANN's space-filling-curve k-NN (Connor and Kumar 2010) from its published
// description. The model is sorted along the Morton (Z-order) curve of a cubic grid over its bounding box.
// A query takes the k points on each side of its own position on the curve as first candidates; their
// k-th distance r bounds the answer, and every point of the box q +- r lies on the curve between the codes
// of the box's two corners, because interleaving bits is monotone in each coordinate. That curve range is
// then refined by bisection: a run of the sorted points lies in the octree cell named by the common prefix
// of its first and last codes, and is skipped when that cell is farther than the current k-th distance.
// Distances are computed in double on a curve-ordered copy of the points.
#include "nnb/best_k.hpp"
#include "nnb/box.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

constexpr int kMaxBits = 21;                 // three axes of 21 bits fill a 64-bit code
constexpr std::uint32_t kScanRun = 16;        // runs this short are scanned rather than bisected
constexpr double kRelativePad = 1e-12;        // far above the few ulps quantisation and box edges can be off


// Puts the low 21 bits of x on every third bit, from bit 0 up.
std::uint64_t spread_bits(std::uint64_t x) {
  x &= 0x1fffffULL;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

// The inverse of spread_bits: gathers every third bit, from bit 0 up.
std::uint32_t gather_bits(std::uint64_t x) {
  x &= 0x1249249249249249ULL;
  x = (x ^ (x >> 2)) & 0x10c30c30c30c30c3ULL;
  x = (x ^ (x >> 4)) & 0x100f00f00f00f00fULL;
  x = (x ^ (x >> 8)) & 0x1f0000ff0000ffULL;
  x = (x ^ (x >> 16)) & 0x1f00000000ffffULL;
  x = (x ^ (x >> 32)) & 0x1fffffULL;
  return static_cast<std::uint32_t>(x);
}

// A cubic grid of 2^bits cells a side over the model's bounding box, and the Morton codes of its cells.
class MortonGrid {
 public:
  MortonGrid() = default;
  MortonGrid(const Cloud& model, int bits) : last_cell_((1u << bits) - 1) {
    const Eigen::Vector3d lo = model.rowwise().minCoeff();
    const Eigen::Vector3d hi = model.rowwise().maxCoeff();
    const double side_m = (hi - lo).maxCoeff();
    for (int a = 0; a < 3; ++a) origin_m_[a] = lo[a];
    cell_m_ = side_m > 0.0 ? side_m / static_cast<double>(1u << bits) : 1.0;
    cells_per_m_ = 1.0 / cell_m_;
    const double magnitude_m = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
    pad_m_ = kRelativePad * (magnitude_m + side_m);
  }

  // Cell index along one axis, clamped to the grid so that points outside it (queries) order correctly.
  std::uint32_t cell(double x_m, int axis) const {
    const double t = (x_m - origin_m_[axis]) * cells_per_m_;
    if (!(t > 0.0)) return 0;
    if (t >= static_cast<double>(last_cell_)) return last_cell_;
    return static_cast<std::uint32_t>(t);
  }

  std::uint64_t code(const double* p) const { return code_shifted(p, 0.0); }

  // The code of the point p + offset_m on every axis: the corners of a query's box.
  std::uint64_t code_shifted(const double* p, double offset_m) const {
    return spread_bits(cell(p[0] + offset_m, 0)) | spread_bits(cell(p[1] + offset_m, 1)) << 1 |
           spread_bits(cell(p[2] + offset_m, 2)) << 2;
  }

  // The smallest octree cell holding both codes, and so every code between them, in metres; padded so
  // that rounding in quantisation and here cannot leave one of its points outside.
  Box cell_box(std::uint64_t first, std::uint64_t last) const {
    const std::uint64_t differ = first ^ last;
    const int free_bits = differ == 0 ? 0 : 3 * ((63 - __builtin_clzll(differ)) / 3 + 1);
    const std::uint64_t mask = free_bits == 0 ? 0 : (~0ULL >> (64 - free_bits));
    const std::uint64_t low = first & ~mask, high = first | mask;
    Box box;
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = origin_m_[a] + static_cast<double>(gather_bits(low >> a)) * cell_m_ - pad_m_;
      box.hi[a] = origin_m_[a] + (static_cast<double>(gather_bits(high >> a)) + 1.0) * cell_m_ + pad_m_;
    }
    return box;
  }

  // How far a query box must reach beyond distance r to hold every point whose computed distance is <= r.
  double padded_reach_m(const double* q, double r_m) const {
    const double magnitude_m = std::max({std::abs(q[0]), std::abs(q[1]), std::abs(q[2])});
    return r_m + kRelativePad * (magnitude_m + r_m) + pad_m_;
  }

 private:
  double origin_m_[3] = {0.0, 0.0, 0.0};
  double cell_m_ = 1.0;
  double cells_per_m_ = 1.0;
  double pad_m_ = 0.0;
  std::uint32_t last_cell_ = 0;
};


// Positions [begin, end) on the curve.
struct Run {
  std::uint32_t begin = 0, end = 0;
  std::uint32_t size() const { return end - begin; }
};

// One k-NN query: its code, its first window of candidates (never offered twice) and the best so far.
struct KnnQuery {
  const double* q;
  std::uint64_t code;
  Run window;
  BestK best;
};

class SfcMorton final : public SearchIndex {
 public:
  explicit SfcMorton(const Params& params) : SearchIndex(describe(params)) {
    bits_ = std::stoi(info().params.at("bits"));
  }

  std::size_t index_bytes() const override {
    return points_.capacity() * sizeof(double) + order_.capacity() * sizeof(PointIndex) +
           codes_.capacity() * sizeof(std::uint64_t) + sizeof(MortonGrid);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "sfc_morton";
    info.concurrency = Concurrency::queries;
    info.library = "ours (this project, after STANN)";
    info.version = "1";
    info.structure = "Morton-order space-filling curve";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_int("bits", kMaxBits, 1, kMaxBits);
    info.params = reader.finish();
    info.notes =
        "STANN is not packaged: rebuilt from Connor and Kumar 2010 (model sorted along the Morton curve of "
        "a cubic grid of 2^bits cells a side over its bounding box, first candidates the k points each side "
        "of the query's curve position, then the curve range between the codes of the corners of the box "
        "q +- k-th distance, bisected and pruned by the octree cell of each run's common code prefix; runs "
        "of 16 scanned); STANN orders by the floating-point bits instead of a grid; ranged starts from the "
        "limit (native), radius searches the ball's box range with the same pruning and an exact <= r*r cut; "
        "boxes padded by 1e-12 of the coordinates so that rounding loses no point";
    return info;
  }

  void do_build(const Cloud& model) override {
    grid_ = MortonGrid(model, bits_);
    const auto n = static_cast<std::size_t>(model.cols());
    std::vector<std::pair<std::uint64_t, PointIndex>> keyed(n);
    for (std::size_t i = 0; i < n; ++i) {
      keyed[i] = {grid_.code(model.col(static_cast<Eigen::Index>(i)).data()), static_cast<PointIndex>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    codes_.resize(n);
    order_.resize(n);
    points_.resize(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      codes_[i] = keyed[i].first;
      order_[i] = keyed[i].second;
      for (int a = 0; a < 3; ++a) points_[3 * i + a] = model(a, static_cast<Eigen::Index>(keyed[i].second));
    }
  }

  const double* point_at(std::uint32_t pos) const { return &points_[3 * static_cast<std::size_t>(pos)]; }
  std::uint32_t size() const { return static_cast<std::uint32_t>(codes_.size()); }

  std::uint32_t first_at_or_after(std::uint64_t code) const {
    return static_cast<std::uint32_t>(std::lower_bound(codes_.begin(), codes_.end(), code) - codes_.begin());
  }
  std::uint32_t first_after(std::uint64_t code) const {
    return static_cast<std::uint32_t>(std::upper_bound(codes_.begin(), codes_.end(), code) - codes_.begin());
  }

  // The run of the curve between the codes of the corners of the box q +- r (r may be infinite).
  Run run_of_box(const double* q, double r_m) const {
    const double reach_m = grid_.padded_reach_m(q, r_m);
    return {first_at_or_after(grid_.code_shifted(q, -reach_m)), first_after(grid_.code_shifted(q, reach_m))};
  }

  bool cell_beyond(const double* q, Run run, double bound_sq_m2) const {
    return sq_dist_to_box_m2(q, grid_.cell_box(codes_[run.begin], codes_[run.end - 1])) > bound_sq_m2;
  }

  void offer_run(KnnQuery& query, std::uint32_t begin, std::uint32_t end) const {
    for (std::uint32_t pos = begin; pos < end; ++pos) query.best.offer(sq_dist_m2(query.q, point_at(pos)), order_[pos]);
  }

  // Offers the run's points outside the first window.
  void scan_outside_window(KnnQuery& query, Run run) const {
    offer_run(query, run.begin, std::min(run.end, query.window.begin));
    offer_run(query, std::max(run.begin, query.window.end), run.end);
  }

  // Bisects the run, the half on the query's side of the curve first, skipping cells beyond the k-th distance.
  void refine_knn(KnnQuery& query, Run run) const {
    if (run.size() == 0) return;
    if (run.size() <= kScanRun) {
      scan_outside_window(query, run);
      return;
    }
    if (cell_beyond(query.q, run, query.best.bound_sq_m2())) return;
    const std::uint32_t mid = run.begin + run.size() / 2;
    const Run low{run.begin, mid}, high{mid, run.end};
    const bool query_below = query.code < codes_[mid];
    refine_knn(query, query_below ? low : high);
    refine_knn(query, query_below ? high : low);
  }

  void nearest_within(const double* q, std::size_t k, double limit_sq_m2, Neighbours& out) const {
    KnnQuery query{q, grid_.code(q), {}, BestK(k, limit_sq_m2)};
    const std::uint32_t pos = first_at_or_after(query.code);
    const auto reach = static_cast<std::uint32_t>(std::min<std::size_t>(k, size()));
    query.window = {pos - std::min(pos, reach), pos + std::min(size() - pos, reach)};
    offer_run(query, query.window.begin, query.window.end);
    refine_knn(query, run_of_box(q, std::sqrt(query.best.bound_sq_m2())));
    query.best.write_sorted(out);
  }

  void k_nearest_within(const Cloud& queries, int k, double limit_sq_m2, Neighbours& out) const {
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      nearest_within(queries.col(q).data(), static_cast<std::size_t>(k), limit_sq_m2, out);
    }
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    k_nearest_within(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    k_nearest_within(queries, k, max_dist_m * max_dist_m, out);
  }

  void collect_ball(const double* q, Run run, double limit_sq_m2, Neighbours& out) const {
    if (run.size() == 0) return;
    if (run.size() > kScanRun) {
      if (cell_beyond(q, run, limit_sq_m2)) return;
      const std::uint32_t mid = run.begin + run.size() / 2;
      collect_ball(q, {run.begin, mid}, limit_sq_m2, out);
      collect_ball(q, {mid, run.end}, limit_sq_m2, out);
      return;
    }
    for (std::uint32_t pos = run.begin; pos < run.end; ++pos) {
      const double sq = sq_dist_m2(q, point_at(pos));
      if (sq <= limit_sq_m2) out.push(order_[pos], sq);
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    for (Eigen::Index i = 0; i < queries.cols(); ++i) {
      const double* q = queries.col(i).data();
      collect_ball(q, run_of_box(q, radius_m), radius_m * radius_m, out);
      out.end_query();
    }
  }

  int bits_ = kMaxBits;
  MortonGrid grid_;
  std::vector<std::uint64_t> codes_;  // Morton codes, ascending
  std::vector<PointIndex> order_;     // model index of each curve position
  std::vector<double> points_;        // x, y, z of each curve position
};

}  // namespace

std::unique_ptr<SearchIndex> make_sfc_morton(const Params& params) { return std::make_unique<SfcMorton>(params); }

}  // namespace nnb::adapters
