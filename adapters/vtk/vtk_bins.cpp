// VTK's uniform-bin point locators, both in double over the model's own memory: vtkPointLocator (a hash
// table of vtkIdList buckets) and vtkStaticPointLocator (point ids sorted by bucket, with offsets). Their
// distances are bit-identical to ours; what needs care is the boundary of the bucket ranges and radius 0.
//
// k-NN is FindClosestNPoints (sorted). Radius is FindPointsWithinRadius (inclusive). Ranged with k = 1 is
// FindClosestPointWithinRadius, VTK's own ranged search; VTK has nothing for k > 1, where ranged is
// FindClosestNPoints cut at the limit.
//
// Far from the grid, in bucket widths, VTK's casts overflow (undefined behaviour; on x86 the index becomes
// bucket 0): FindClosestPointWithinRadius casts (search radius / bucket width) to int and, beyond 2^31 widths
// (a query 1e9 m from a model of 10 cm buckets), returned a point 1e9 m farther than the nearest; every search
// casts (coordinate - grid origin) / width to a 64-bit index, which overflows 2^63 widths away (a query
// 1e15 m from a model of 0.1 mm buckets; a radius search there found 4 to 6 of 1000 points). The adapter keeps
// every search inside those ranges: radii are clipped to the farthest corner of the grid (exact: no point
// lies beyond it), FindClosestPointWithinRadius gives way to FindClosestNPoints beyond 2^30 widths, and
// queries beyond 2^61 widths, which no VTK call can answer, are answered by a scan of the model in double.
#include "nnb/registry.hpp"
#include "vtk_common.hpp"

#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkPointLocator.h>
#include <vtkSmartPointer.h>
#include <vtkStaticPointLocator.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using vtk::build_single_threaded;
using vtk::point_set;

// vtkPointLocator with its bucket table's size made readable (VTK reports none).
class CountedPointLocator final : public vtkPointLocator {
 public:
  static CountedPointLocator* New() { return vtk::new_vtk_object<CountedPointLocator>(); }
  /// Bytes of the table: one pointer per bucket and each non-empty bucket's vtkIdList, its ids counted at
  /// the larger of their number and the NumberOfPointsPerBucket allocated first (the capacity is not readable).
  std::size_t table_bytes() const {
    if (!HashTable) return 0;
    std::size_t bytes = static_cast<std::size_t>(NumberOfBuckets) * sizeof(vtkIdList*);
    for (vtkIdType b = 0; b < NumberOfBuckets; ++b) {
      if (!HashTable[b]) continue;
      const vtkIdType ids = std::max<vtkIdType>(HashTable[b]->GetNumberOfIds(), NumberOfPointsPerBucket);
      bytes += sizeof(vtkIdList) + static_cast<std::size_t>(ids) * sizeof(vtkIdType);
    }
    return bytes;
  }
};

struct PointLocator {
  using Locator = CountedPointLocator;
  static constexpr const char* name = "vtk_pointlocator";
  static constexpr const char* structure = "uniform bins (hash table of id lists)";
  static constexpr int default_points_per_bucket = 3;  // vtkPointLocator's constructor
  // Its searches fill the locator's own scratch lists: one thread at a time.
  static constexpr Concurrency concurrency = Concurrency::single;
  static std::size_t bytes(Locator& locator, std::size_t) { return locator.table_bytes(); }
};

struct StaticPointLocator {
  using Locator = vtkStaticPointLocator;
  static constexpr const char* name = "vtk_static";
  static constexpr const char* structure = "uniform bins (ids sorted by bin)";
  static constexpr int default_points_per_bucket = 1;  // vtkStaticPointLocator's constructor
  // VTK documents its searches as thread-safe once the locator is built (build() builds it).
  static constexpr Concurrency concurrency = Concurrency::queries;
  // A (point id, bucket) pair per point plus one, and an offset per bucket plus one, in int or vtkIdType.
  static std::size_t bytes(Locator& locator, std::size_t n_points) {
    const std::size_t id_bytes = locator.GetLargeIds() ? sizeof(vtkIdType) : sizeof(int);
    return (n_points + 1) * 2 * id_bytes + static_cast<std::size_t>(locator.GetNumberOfBuckets() + 1) * id_bytes;
  }
};

// The radius to hand VTK for an exact search of radius_m around query: bucket ranges come from query +-
// radius rounded in double, so a hair wider (1e-12 relative, plus 1e-15 of the coordinates, far above
// their rounding) loses no point within radius_m; the floor keeps it positive at radius 0, where
// FindClosestPointWithinRadius's strict test (dist2 < 1.01 r^2) would otherwise miss coincident points.
double widened_radius_m(const double* query, double radius_m) {
  const double magnitude_m = std::max({std::abs(query[0]), std::abs(query[1]), std::abs(query[2])});
  return radius_m * (1.0 + 1e-12) + 1e-15 * magnitude_m + 1e-100;
}

// The locator's grid after BuildLocator, and how far a search reaches in bucket widths.
class Grid {
 public:
  void fit(const double* bounds, const int* divisions) {
    for (int d = 0; d < 3; ++d) {
      centre_m_[d] = 0.5 * (bounds[2 * d] + bounds[2 * d + 1]);
      half_width_m_[d] = 0.5 * (bounds[2 * d + 1] - bounds[2 * d]);
      bucket_m_[d] = (bounds[2 * d + 1] - bounds[2 * d]) / divisions[d];
    }
  }
  /// Distance (metres) from query to the grid's farthest corner: no model point lies farther.
  double farthest_corner_m(const double* query) const {
    double sq = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double far_m = std::abs(query[d] - centre_m_[d]) + half_width_m_[d];
      sq += far_m * far_m;
    }
    return std::sqrt(sq) * (1.0 + 1e-12);
  }
  /// The largest number of bucket widths between the grid's centre and a point within reach_m of query.
  double reach_in_buckets(const double* query, double reach_m) const {
    double buckets = 0.0;
    for (int d = 0; d < 3; ++d) {
      buckets = std::max(buckets, (std::abs(query[d] - centre_m_[d]) + reach_m) / bucket_m_[d]);
    }
    return buckets;
  }
  /// reach_m in widths of the narrowest bucket side.
  double in_buckets(double reach_m) const {
    return reach_m / std::min({bucket_m_[0], bucket_m_[1], bucket_m_[2]});
  }

 private:
  double centre_m_[3] = {0, 0, 0};
  double half_width_m_[3] = {0, 0, 0};
  double bucket_m_[3] = {1, 1, 1};
};

// Below 2^63 (vtkIdType) and 2^31 (int) with room for rounding and for the grid's own extent.
constexpr double kMaxIndexBuckets = 0x1p61;
constexpr double kMaxLevelBuckets = 0x1p30;

template <class Variant>
class VtkBins final : public SearchIndex {
 public:
  explicit VtkBins(const Params& params) : SearchIndex(describe(params)) {
    points_per_bucket_ = info().bucket->value;
  }

  std::size_t index_bytes() const override {
    return locator_ ? Variant::bytes(*locator_, model_size()) : 0;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = Variant::name;
    info.concurrency = Variant::concurrency;
    info.library = "VTK";
    info.version = vtk::vtk_version();
    info.structure = Variant::structure;
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_bucket("points_per_bucket", Variant::default_points_per_bucket, 1, 1 << 20, 1, 64);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "double over the model's memory, distances bit-identical to brute force; ranged k=1 is "
        "FindClosestPointWithinRadius, k>1 FindClosestNPoints cut at <= d (VTK has no k>1 ranged call); "
        "radius and ranged searched 1e-12 relative + 1e-15 of the coordinates wider and cut at <= r "
        "(FindClosestPointWithinRadius misses coincident points at r=0), never beyond the grid's farthest corner; "
        "where VTK's casts would overflow, ranged k=1 beyond 2^30 bucket widths uses FindClosestNPoints and queries "
        "beyond 2^61 widths are a scan in double; BuildLocator in build(), on one thread";
    return info;
  }

  void do_build(const Cloud& model) override {
    model_ = &model;
    // VTK reads the model where it is (save = 1: VTK never frees it), tuples of x, y, z as Eigen stores them.
    coords_ = vtkSmartPointer<vtkDoubleArray>::New();
    coords_->SetNumberOfComponents(3);
    coords_->SetArray(const_cast<double*>(model.data()), static_cast<vtkIdType>(model.size()), 1);
    data_ = point_set(coords_);
    locator_ = vtkSmartPointer<typename Variant::Locator>::New();
    locator_->SetNumberOfPointsPerBucket(points_per_bucket_);
    locator_->SetDataSet(data_);
    build_single_threaded([&] { locator_->BuildLocator(); });
    grid_.fit(locator_->GetBounds(), locator_->GetDivisions());
  }

  // Every model point with sq_dist_m2 <= limit_sq_m2, nearest first, at most k: for queries beyond VTK's range.
  void push_scanned(const double* query, std::size_t k, double limit_sq_m2, Neighbours& out) const {
    std::vector<std::pair<double, PointIndex>> rows;
    for (Eigen::Index i = 0; i < model_->cols(); ++i) {
      const double sq = sq_dist_m2(query, model_->col(i).data());
      if (sq <= limit_sq_m2) rows.emplace_back(sq, static_cast<PointIndex>(i));
    }
    const std::size_t kept = std::min(k, rows.size());
    std::partial_sort(rows.begin(), rows.begin() + static_cast<std::ptrdiff_t>(kept), rows.end());
    for (std::size_t i = 0; i < kept; ++i) out.push(rows[i].second, rows[i].first);
    out.end_query();
  }

  bool beyond_index_range(const double* query, double reach_m) const {
    return !(grid_.reach_in_buckets(query, reach_m) < kMaxIndexBuckets);
  }

  void push_found(const double* query, vtkIdList& ids, double limit_sq_m2, Neighbours& out) const {
    for (vtkIdType i = 0; i < ids.GetNumberOfIds(); ++i) {
      const vtkIdType index = ids.GetId(i);
      const double sq = sq_dist_m2(query, model_->col(index).data());
      if (sq <= limit_sq_m2) out.push(static_cast<PointIndex>(index), sq);
    }
    out.end_query();
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(k) * queries.cols());
    auto ids = vtkSmartPointer<vtkIdList>::New();
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      const double inf = std::numeric_limits<double>::infinity();
      if (beyond_index_range(query, grid_.farthest_corner_m(query))) {
        push_scanned(query, static_cast<std::size_t>(k), inf, out);
        continue;
      }
      locator_->FindClosestNPoints(k, query, ids);
      push_found(query, *ids, inf, out);
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    auto ids = vtkSmartPointer<vtkIdList>::New();
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      const double search_m = std::min(widened_radius_m(query, radius_m), grid_.farthest_corner_m(query));
      if (beyond_index_range(query, search_m)) {
        push_scanned(query, model_size(), radius_m * radius_m, out);
        continue;
      }
      locator_->FindPointsWithinRadius(search_m, query, ids);
      push_found(query, *ids, radius_m * radius_m, out);
    }
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    if (k > 1) {
      do_knn(queries, k, out);
      filter_by_sq_dist(max_dist_m * max_dist_m, out);
      return;
    }
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(queries.cols()));
    const double limit_sq_m2 = max_dist_m * max_dist_m;
    auto ids = vtkSmartPointer<vtkIdList>::New();
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      const double search_m = std::min(widened_radius_m(query, max_dist_m), grid_.farthest_corner_m(query));
      if (beyond_index_range(query, search_m)) {
        push_scanned(query, 1, limit_sq_m2, out);
        continue;
      }
      // The nearest point within the wider radius: when it lies beyond the limit, so does every point.
      const vtkIdType index = nearest_within(query, search_m, *ids);
      if (index >= 0) {
        const double sq = sq_dist_m2(query, model_->col(index).data());
        if (sq <= limit_sq_m2) out.push(static_cast<PointIndex>(index), sq);
      }
      out.end_query();
    }
  }

  // The nearest model point within search_m of query, or -1; FindClosestNPoints where the search would span
  // more buckets than FindClosestPointWithinRadius's int levels hold.
  vtkIdType nearest_within(const double* query, double search_m, vtkIdList& ids) const {
    if (grid_.in_buckets(search_m) < kMaxLevelBuckets) {
      double vtk_sq_m2 = -1.0;
      return locator_->FindClosestPointWithinRadius(search_m, query, vtk_sq_m2);
    }
    locator_->FindClosestNPoints(1, query, &ids);
    return ids.GetId(0);
  }

  int points_per_bucket_ = 1;
  Grid grid_;
  const Cloud* model_ = nullptr;
  vtkSmartPointer<vtkDoubleArray> coords_;
  vtkSmartPointer<vtkPolyData> data_;
  vtkSmartPointer<typename Variant::Locator> locator_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_vtk_pointlocator(const Params& params) {
  return std::make_unique<VtkBins<PointLocator>>(params);
}

std::unique_ptr<SearchIndex> make_vtk_static(const Params& params) {
  return std::make_unique<VtkBins<StaticPointLocator>>(params);
}

}  // namespace nnb::adapters
