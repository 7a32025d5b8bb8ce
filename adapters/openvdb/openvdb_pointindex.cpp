// OpenVDB's point index grid (openvdb::tools::PointIndexGrid): the model's point indices bucketed by voxel in a
// sparse VDB tree (leaves of 8^3 voxels under two levels of internal nodes), searched by PointIndexIterator.
// Its search is a radius search (a sphere in world space, each point in a voxel the sphere cuts tested; whole
// voxels and leaves inside it taken untested). It has no k-NN: k-NN and ranged search go via radius.
//
// The voxel size is OpenVDB's own choice for a number of points a voxel (points::computeVoxelSize, which
// refines a bounding-box estimate by the voxels the points occupy), in a frame centred on the model's box so
// that voxel coordinates (32-bit) stay small; the points stay the caller's, read through the PointArray
// interface. Its tests are strict (< r) and in index space, so radii are widened and the rows cut at <= r on
// distances recomputed from the model.
#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/tools/PointIndexGrid.h>
#include <tbb/task_arena.h>
#ifdef NNB_OPENVDB_STOPS_LOG4CPLUS
#include <log4cplus/config.hxx>
#endif

#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

#ifdef NNB_OPENVDB_STOPS_LOG4CPLUS
// Debian's OpenVDB logs through log4cplus, whose library starts a pool of threads as it is loaded: every process
// linking the adapters carried its idle threads, and a forked child hung at exit waiting for the ones fork did
// not copy (Threads.AForkedChildAnswersOnThreadsOfItsOwnAndExits). Stopped at start: logging still works after,
// on the calling thread.
const bool kLog4cplusPoolStopped = [] {
  log4cplus::deinitialize();
  return true;
}();
#endif

using Grid = openvdb::tools::PointIndexGrid;
using Searcher = openvdb::tools::PointIndexIterator<openvdb::tools::PointIndexTree>;

// The model as OpenVDB's PointArray interface reads it, in place.
struct ModelPoints {
  using PosType = openvdb::Vec3d;
  using value_type = openvdb::Vec3d;
  const Cloud* cloud = nullptr;
  std::size_t size() const { return static_cast<std::size_t>(cloud->cols()); }
  void getPos(std::size_t n, PosType& xyz) const {
    const double* p = cloud->col(static_cast<Eigen::Index>(n)).data();
    xyz = PosType(p[0], p[1], p[2]);
  }
};

// Voxels no smaller than this share of the box's longest edge: voxel coordinates within the box stay below
// 2^20, whatever the box's proportions.
constexpr double kMinVoxelShareOfExtent = 1.0 / (1 << 20);
// A search whose ball reaches this many voxels from the model's centre would overflow OpenVDB's 32-bit voxel
// coordinates: it searches the model's box instead (the same points, each then tested against the ball).
constexpr double kMaxSearchVoxels = 1 << 28;

class OpenVdbPointIndex final : public SearchIndex {
 public:
  explicit OpenVdbPointIndex(const Params& params) : SearchIndex(describe(params)) { openvdb::initialize(); }

  // The grid's tree (the point indices, 4 bytes each, in its leaves); the points are the caller's.
  std::size_t index_bytes() const override { return grid_ ? static_cast<std::size_t>(grid_->memUsage()) : 0; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "openvdb_pointindex";
    info.library = "OpenVDB";
    info.version = openvdb::getLibraryVersionString();
    info.structure = "sparse voxel tree (VDB) of point indices";
    info.scalar = "double";
    info.knn = Strategy::via_radius;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_radius;
    info.concurrency = Concurrency::queries;  // each batch its own accessor and iterator over a grid read only
    info.builds_on_threads = true;            // OpenVDB builds on TBB: an arena of threads()
    ParamReader reader(info.name, params);
    reader.get_bucket("points_per_voxel", 8, 1, 1 << 20, 1, 64);
    info.bucket = reader.bucket();
    info.params = reader.finish();
    info.notes =
        "voxel size from points::computeVoxelSize (OpenVDB's own, for points_per_voxel), at least 2^-20 of the "
        "box's longest edge, in a frame centred on the box; radii widened by 1e-12 of (|query| + |centre| + the "
        "box's diagonal + r) and one ulp (its tests are strict and in voxel units), rows cut at <= r on "
        "distances recomputed from the model; queries farther than r from the box skipped, balls reaching 2^28 "
        "voxels searched as the box; k-NN doubles a radius from max(voxel, distance to the box) until k points "
        "lie within it; log4cplus's thread pool stopped at start";
    return info;
  }

  void do_build(const Cloud& model) override {
    model_.cloud = &model;
    lo_ = model.rowwise().minCoeff();
    hi_ = model.rowwise().maxCoeff();
    centre_ = 0.5 * (lo_ + hi_);
    extent_m_ = (hi_ - lo_).maxCoeff();
    scale_m_ = centre_.cwiseAbs().maxCoeff() + (hi_ - lo_).norm();
    openvdb::math::Mat4d frame = openvdb::math::Mat4d::identity();
    frame.setTranslation(openvdb::Vec3d(centre_[0], centre_[1], centre_[2]));
    tbb::task_arena arena(build_threads_used());
    arena.execute([&] {
      const auto points_per_voxel = static_cast<std::uint32_t>(info().bucket->value);
      voxel_m_ = std::max(static_cast<double>(openvdb::points::computeVoxelSize(model_, points_per_voxel, frame)),
                          kMinVoxelShareOfExtent * extent_m_);
      transform_ = openvdb::math::Transform::createLinearTransform(voxel_m_);
      transform_->postTranslate(openvdb::Vec3d(centre_[0], centre_[1], centre_[2]));
      grid_ = openvdb::tools::createPointIndexGrid<Grid>(model_, *transform_);
    });
  }

  // radius_m widened past OpenVDB's rounding: its strict test, and the query and radius taken to voxel units.
  double widened_m(double radius_m, const double* query) const {
    const double query_m = std::max({std::abs(query[0]), std::abs(query[1]), std::abs(query[2])});
    return std::max(next_up(radius_m + 1e-12 * (query_m + scale_m_ + radius_m)), 1e-150);
  }

  double sq_dist_to_box_m2(const double* query) const {
    double sq_m2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double out_m = std::max({lo_[d] - query[d], query[d] - hi_[d], 0.0});
      sq_m2 += out_m * out_m;
    }
    return sq_m2;
  }

  // Appends to row every model point within radius_m of query, as (squared distance, index), unsorted.
  void points_within(const double* query, double radius_m, Searcher::ConstAccessor& accessor, Searcher& searcher,
                     std::vector<std::pair<double, PointIndex>>& row) const {
    const double limit_sq_m2 = radius_m * radius_m;
    if (sq_dist_to_box_m2(query) > limit_sq_m2) return;
    const double search_m = widened_m(radius_m, query);
    const openvdb::Vec3d centre(query[0], query[1], query[2]);
    const double reach_voxels = ((centre - openvdb::Vec3d(centre_[0], centre_[1], centre_[2])).length() + search_m) /
                                voxel_m_;
    if (reach_voxels < kMaxSearchVoxels) {
      searcher.worldSpaceSearchAndUpdate(centre, search_m, accessor, model_, *transform_);
    } else {
      const openvdb::BBoxd box(openvdb::Vec3d(lo_[0], lo_[1], lo_[2]), openvdb::Vec3d(hi_[0], hi_[1], hi_[2]));
      searcher.worldSpaceSearchAndUpdate(box, accessor, model_, *transform_);
    }
    for (; searcher; ++searcher) {
      const auto index = static_cast<PointIndex>(*searcher);
      const double sq_m2 = sq_dist_m2(query, model_.cloud->col(static_cast<Eigen::Index>(index)).data());
      if (sq_m2 <= limit_sq_m2) row.emplace_back(sq_m2, index);
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    Searcher::ConstAccessor accessor(grid_->constTree());
    Searcher searcher;
    std::vector<std::pair<double, PointIndex>> row;
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      row.clear();
      points_within(queries.col(q).data(), radius_m, accessor, searcher, row);
      for (const auto& [sq_m2, index] : row) out.push(index, sq_m2);
      out.end_query();
    }
  }

  // A radius search that finds at least k points within its radius holds the k nearest (every point within it
  // is found, ties included), so each query doubles its radius until it does, from the voxel size or its
  // distance to the model's box; a ball holding the whole box holds every point.
  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto kk = std::min(static_cast<std::size_t>(k), model_size());
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(queries.cols()) * kk);
    Searcher::ConstAccessor accessor(grid_->constTree());
    Searcher searcher;
    std::vector<std::pair<double, PointIndex>> row;
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      double radius_m = std::max(voxel_m_, std::sqrt(sq_dist_to_box_m2(query)));
      for (row.clear(); points_within(query, radius_m, accessor, searcher, row), row.size() < kk; row.clear()) {
        radius_m *= 2.0;
      }
      std::partial_sort(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(kk), row.end());
      for (std::size_t i = 0; i < kk; ++i) out.push(row[i].second, row[i].first);
      out.end_query();
    }
  }

  ModelPoints model_;
  Eigen::Vector3d lo_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d hi_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  double extent_m_ = 0.0;
  double scale_m_ = 0.0;
  double voxel_m_ = 0.0;
  openvdb::math::Transform::Ptr transform_;
  Grid::Ptr grid_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_openvdb_pointindex(const Params& params) {
  return std::make_unique<OpenVdbPointIndex>(params);
}

}  // namespace nnb::adapters
