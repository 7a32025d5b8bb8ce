// Open3D's spatial hash (core::nns::FixedRadiusIndex, CPU, Float64 tensors): the points are binned into
// voxels of 2r hashed into n/32 cells, and a query visits the cells of its own voxel and of its 8 corners
// at +-r, testing d^2 <= r^2. The table is built for one radius and only answers that radius, so one table is
// kept per radius asked (built on first use, the time counted in that query). Radius search is native;
// ranged is that radius search then the k nearest; k-NN, which Open3D does not offer here (SearchKnn and, on
// CPU, SearchHybrid throw), grows the radius by factors of 2 until k points lie inside.
#include <open3d/Open3DConfig.h>
#include <open3d/core/Tensor.h>
#include <open3d/core/nns/FixedRadiusIndex.h>
#include <tbb/task_arena.h>

#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using open3d::core::Tensor;
using open3d::core::nns::FixedRadiusIndex;

/// Model indices found per query, in compressed rows.
struct Rows {
  std::vector<std::int64_t> splits{0};
  std::vector<std::int64_t> indices;

  void clear() {
    splits.assign(1, 0);
    indices.clear();
  }
  void append_row(const Rows& from, std::size_t row) {
    indices.insert(indices.end(), from.indices.begin() + from.splits[row], from.indices.begin() + from.splits[row + 1]);
    splits.push_back(static_cast<std::int64_t>(indices.size()));
  }
};

class Open3dHash final : public SearchIndex {
 public:
  explicit Open3dHash(const Params& params) : SearchIndex(describe(params)), arena_(1) {
    build_radius_m_ = std::stod(info().params.at("radius_m"));
  }

  // The model in the hash's frame (Float64, 24 bytes a point) and, per table, a uint32 point index per point
  // plus n/32 + 1 uint32 cell bounds.
  std::size_t index_bytes() const override {
    const std::size_t n = model_size();
    return n * 3 * sizeof(double) + tables_.size() * (n * 4 + (std::max<std::size_t>(n / 32, 1) + 1) * 4);
  }

 private:
  // More tables than a k-NN's radius ladder usually climbs; the least recently used goes beyond that.
  static constexpr std::size_t kMaxTables = 8;

  struct Table {
    double hash_radius_m = 0.0;
    std::uint64_t last_use = 0;
    std::unique_ptr<FixedRadiusIndex> index;
  };

  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "open3d_hashgrid";
    info.library = "Open3D";
    info.version = OPEN3D_VERSION;
    info.structure = "spatial hash (voxels of 2r, one table per radius)";
    info.scalar = "double";
    info.knn = Strategy::via_radius;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_radius;
    info.exact = true;
    ParamReader reader(info.name, params);
    reader.get_double("radius_m", 0.25, 1e-9, 1e15);  // the table build() makes; the k-NN ladder starts here
    info.params = reader.finish();
    info.notes =
        "FixedRadiusIndex hashes for one radius: build() makes the table for radius_m, any other radius builds "
        "its own on first use (inside that query's time; 8 kept, least recently used dropped); points relative "
        "to the model's box centre, searched 1e-12 wider (radius 0 too) and at least 1e-9 of the extent so voxel "
        "numbers fit Open3D's int, queries beyond the model's box skipped, a query whose corners span 3 voxels "
        "searched at 2r; distances recomputed in double, cut at <= r; k-NN grows the radius by 2 from radius_m "
        "(or the box distance) until k points lie within it; one core (TBB arena of 1); not thread-safe";
    return info;
  }

  void do_build(const Cloud& model) override {
    const Eigen::Vector3d lo = model.rowwise().minCoeff();
    const Eigen::Vector3d hi = model.rowwise().maxCoeff();
    origin_ = 0.5 * (lo + hi);
    const auto n = model.cols();
    points_ = Tensor::Empty({n, 3}, open3d::core::Float64);
    double* frame_points = points_.GetDataPtr<double>();
    for (Eigen::Index i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) frame_points[3 * i + d] = model(d, i) - origin_[d];
    }
    // The box of the points as the hash sees them (rounded like them), for the test that skips far queries.
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic>> frame(frame_points, 3, n);
    frame_lo_ = frame.rowwise().minCoeff();
    frame_hi_ = frame.rowwise().maxCoeff();
    magnitude_m_ = std::max(frame_lo_.cwiseAbs().maxCoeff(), frame_hi_.cwiseAbs().maxCoeff());
    model_ = &model;
    tables_.clear();
    table_for(hash_radius_m(build_radius_m_));
  }

  /// Radius (m) of the table that answers radius_m exactly: 1e-12 wider for the library's own rounding and
  /// the frame's (1e-14 of the extent), positive for radius 0 (Open3D refuses 0), and at least 1e-9 of the
  /// extent so that voxel numbers (coordinate / 2r) stay far inside int, which Open3D casts them to.
  double hash_radius_m(double radius_m) const {
    const double search_m = radius_m * (1.0 + 1e-12) + 1e-14 * magnitude_m_ + 1e-100;
    return std::max(search_m, 1e-9 * magnitude_m_);
  }

  /// The table for hash_radius_m, built now if it is not kept.
  const FixedRadiusIndex& table_for(double hash_radius_m) const {
    ++use_count_;
    for (auto& table : tables_) {
      if (table.hash_radius_m == hash_radius_m) {
        table.last_use = use_count_;
        return *table.index;
      }
    }
    if (tables_.size() >= kMaxTables) {
      tables_.erase(std::min_element(tables_.begin(), tables_.end(),
                                     [](const Table& a, const Table& b) { return a.last_use < b.last_use; }));
    }
    auto index = std::make_unique<FixedRadiusIndex>();
    arena_.execute([&] { index->SetTensorData(points_, hash_radius_m); });
    tables_.push_back(Table{hash_radius_m, use_count_, std::move(index)});
    return *tables_.back().index;
  }

  /// Query columns in the hash's frame, row-major (x, y, z per query).
  std::vector<double> to_frame(const Cloud& queries) const {
    std::vector<double> frame(static_cast<std::size_t>(queries.cols()) * 3);
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      for (int d = 0; d < 3; ++d) frame[3 * q + d] = queries(d, q) - origin_[d];
    }
    return frame;
  }

  /// Squared distance (m^2) from a point in the frame to the model's box.
  double sq_dist_to_box_m2(const double* p) const {
    double sum = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double out = std::max({frame_lo_[d] - p[d], 0.0, p[d] - frame_hi_[d]});
      sum += out * out;
    }
    return sum;
  }

  /// Whether a table of hash_radius_m misses a voxel this query needs: Open3D visits the voxels of the query
  /// and of its corners at +-r; when rounding stretches p-r .. p+r over three voxels along an axis, the middle
  /// one is visited only with the query's own voxel on the other axes. Same arithmetic as Open3D's.
  static bool corners_span_three_voxels(const double* p, double hash_radius_m) {
    const double inv_voxel = 1.0 / (2.0 * hash_radius_m);
    for (int d = 0; d < 3; ++d) {
      if (std::floor((p[d] + hash_radius_m) * inv_voxel) - std::floor((p[d] - hash_radius_m) * inv_voxel) >= 2.0) {
        return true;
      }
    }
    return false;
  }

  /// Every point within hash_radius_m of the queries listed in which (indices into frame_queries), in rows
  /// ordered as which; a superset of the exact answer, to be filtered in double. Queries farther than
  /// hash_radius_m from the model's box get empty rows without reaching Open3D (their voxel numbers could
  /// overflow its int).
  void search(const std::vector<double>& frame_queries, const std::vector<std::size_t>& which, double hash_radius_m,
              Rows& rows) const {
    std::vector<std::size_t> direct, wider;
    std::vector<char> source(which.size());  // 0: no point near, 1: direct, 2: wider
    const double reach_sq_m2 = hash_radius_m * hash_radius_m * (1.0 + 1e-12);
    for (std::size_t i = 0; i < which.size(); ++i) {
      const double* p = &frame_queries[3 * which[i]];
      if (sq_dist_to_box_m2(p) > reach_sq_m2) continue;
      const bool wide = corners_span_three_voxels(p, hash_radius_m);
      (wide ? wider : direct).push_back(which[i]);
      source[i] = wide ? 2 : 1;
    }
    Rows direct_rows, wider_rows;
    run_table(frame_queries, direct, hash_radius_m, direct_rows);
    if (!wider.empty()) search(frame_queries, wider, 2.0 * hash_radius_m, wider_rows);  // at 2r: 2 voxels at most
    if (direct.size() == which.size()) {
      rows = std::move(direct_rows);
      return;
    }
    rows.clear();
    std::size_t next_direct = 0, next_wider = 0;
    for (const char from : source) {
      if (from == 1) {
        rows.append_row(direct_rows, next_direct++);
      } else if (from == 2) {
        rows.append_row(wider_rows, next_wider++);
      } else {
        rows.splits.push_back(static_cast<std::int64_t>(rows.indices.size()));
      }
    }
  }

  /// One batched SearchRadius over the listed queries.
  void run_table(const std::vector<double>& frame_queries, const std::vector<std::size_t>& which,
                 double hash_radius_m, Rows& rows) const {
    rows.clear();
    if (which.empty()) return;
    const auto m = static_cast<std::int64_t>(which.size());
    Tensor batch = Tensor::Empty({m, 3}, open3d::core::Float64);
    double* batch_points = batch.GetDataPtr<double>();
    for (std::size_t i = 0; i < which.size(); ++i) {
      std::copy_n(&frame_queries[3 * which[i]], 3, batch_points + 3 * i);
    }
    const FixedRadiusIndex& table = table_for(hash_radius_m);
    Tensor indices, splits;
    arena_.execute([&] {
      auto found = table.SearchRadius(batch, hash_radius_m, false);
      indices = std::get<0>(found).To(open3d::core::Int64).Contiguous();
      splits = std::get<2>(found).To(open3d::core::Int64).Contiguous();
    });
    const std::int64_t* index_data = indices.GetDataPtr<std::int64_t>();
    const std::int64_t* split_data = splits.GetDataPtr<std::int64_t>();
    rows.indices.assign(index_data, index_data + indices.NumElements());
    rows.splits.assign(split_data, split_data + splits.NumElements());
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    std::vector<std::size_t> all(n_queries);
    for (std::size_t q = 0; q < n_queries; ++q) all[q] = q;
    Rows rows;
    search(to_frame(queries), all, hash_radius_m(radius_m), rows);
    const double limit_sq_m2 = radius_m * radius_m;
    out.reset(n_queries, rows.indices.size());
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      for (auto i = rows.splits[q]; i < rows.splits[q + 1]; ++i) {
        const auto index = static_cast<PointIndex>(rows.indices[static_cast<std::size_t>(i)]);
        const double sq_m2 = sq_dist_m2(query, model_->col(index).data());
        if (sq_m2 <= limit_sq_m2) out.push(index, sq_m2);
      }
      out.end_query();
    }
  }

  // A radius search that finds at least k points within its radius holds the k nearest (every point within
  // it is found, ties included), so each query climbs radius_m * 2^level until it does. A query starts at the
  // first level that reaches the model's box.
  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto kk = static_cast<std::size_t>(k);
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const std::vector<double> frame_queries = to_frame(queries);
    std::vector<int> level(n_queries);
    std::vector<std::size_t> pending(n_queries);
    for (std::size_t q = 0; q < n_queries; ++q) {
      pending[q] = q;
      const double box_m = std::sqrt(sq_dist_to_box_m2(&frame_queries[3 * q]));
      level[q] = box_m > build_radius_m_ ? static_cast<int>(std::ceil(std::log2(box_m / build_radius_m_))) : 0;
    }
    std::vector<std::pair<double, PointIndex>> best(n_queries * kk);  // row q: the k nearest of query q
    std::vector<std::size_t> which, still_pending;
    std::vector<std::pair<double, PointIndex>> row;
    Rows rows;
    while (!pending.empty()) {
      const int lowest = level[*std::min_element(pending.begin(), pending.end(),
                                                 [&](std::size_t a, std::size_t b) { return level[a] < level[b]; })];
      const double radius_m = std::ldexp(build_radius_m_, lowest);
      which.clear();
      still_pending.clear();
      for (const std::size_t q : pending) (level[q] == lowest ? which : still_pending).push_back(q);
      search(frame_queries, which, hash_radius_m(radius_m), rows);
      for (std::size_t i = 0; i < which.size(); ++i) {
        const std::size_t q = which[i];
        const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
        row.clear();
        for (auto j = rows.splits[i]; j < rows.splits[i + 1]; ++j) {
          const auto index = static_cast<PointIndex>(rows.indices[static_cast<std::size_t>(j)]);
          const double sq_m2 = sq_dist_m2(query, model_->col(index).data());
          if (sq_m2 <= radius_m * radius_m) row.emplace_back(sq_m2, index);
        }
        if (row.size() >= kk) {
          std::partial_sort(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(kk), row.end());
          std::copy_n(row.begin(), kk, best.begin() + static_cast<std::ptrdiff_t>(q * kk));
        } else {
          ++level[q];
          still_pending.push_back(q);
        }
      }
      pending.swap(still_pending);
    }
    out.reset(n_queries, n_queries * kk);
    for (std::size_t q = 0; q < n_queries; ++q) {
      for (std::size_t i = q * kk; i < (q + 1) * kk; ++i) out.push(best[i].second, best[i].first);
      out.end_query();
    }
  }

  double build_radius_m_ = 0.25;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d frame_lo_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d frame_hi_ = Eigen::Vector3d::Zero();
  double magnitude_m_ = 0.0;
  Tensor points_;  // the model relative to origin_, shared by every table
  const Cloud* model_ = nullptr;
  // Tables are built on a query's first use of a radius: the cache is the only state a query changes.
  mutable std::vector<Table> tables_;
  mutable std::uint64_t use_count_ = 0;
  mutable tbb::task_arena arena_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_open3d_hashgrid(const Params& params) {
  return std::make_unique<Open3dHash>(params);
}

}  // namespace nnb::adapters
