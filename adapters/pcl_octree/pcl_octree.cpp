// PCL's octree, pcl::octree::OctreePointCloudSearch<PointXYZ>, float. Two adapters over one class:
// pcl_octree (exact k-NN and radius search; ranged = k-NN then a distance cut) and pcl_octree_approx
// (PCL's approxNearestSearch: descends to one leaf and returns its closest point; 1-NN only, inexact).
#include <pcl/octree/octree_search.h>
#include <pcl/pcl_config.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "../float_libs/pcl_search.hpp"
#include "nnb/registry.hpp"

#include <cmath>
#include <cstdint>
#include <memory>
#include <unordered_set>
#include <vector>

namespace nnb::adapters {
namespace {

using Octree = pcl::octree::OctreePointCloudSearch<pcl::PointXYZ>;

/// Edge length (m) of cubic voxels that hold about points_per_leaf points of model on average over the
/// occupied ones: starts from the bounding box as if the points filled it, then corrects a few times by
/// counting occupied voxels (surfaces fill voxels more sparsely than volumes do).
double auto_resolution_m(const Cloud& model, double points_per_leaf) {
  const Eigen::Vector3d lo = model.rowwise().minCoeff();
  const Eigen::Vector3d extent = model.rowwise().maxCoeff() - lo;
  const double largest_m = extent.maxCoeff();
  if (!(largest_m > 0.0)) return 1.0;  // all points equal: any voxel size works
  const auto n = static_cast<double>(model.cols());
  double resolution_m = largest_m / std::cbrt(std::max(1.0, n / points_per_leaf));
  std::unordered_set<std::uint64_t> occupied;
  for (int round = 0; round < 4; ++round) {
    occupied.clear();
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      const Eigen::Array3d cell = ((model.col(i) - lo).array() / resolution_m).floor();
      const auto x = static_cast<std::uint64_t>(cell[0]), y = static_cast<std::uint64_t>(cell[1]),
                 z = static_cast<std::uint64_t>(cell[2]);
      occupied.insert((x * 0x9E3779B97F4A7C15ull) ^ (y * 0xC2B2AE3D27D4EB4Full) ^ (z * 0x165667B19E3779F9ull));
    }
    const double per_leaf = n / static_cast<double>(occupied.size());
    if (per_leaf > 0.7 * points_per_leaf && per_leaf < 1.4 * points_per_leaf) break;
    resolution_m *= std::pow(points_per_leaf / per_leaf, 1.0 / 2.5);  // between surface (2) and volume (3)
  }
  return resolution_m;
}

class PclOctree final : public SearchIndex {
 public:
  PclOctree(const Params& params, bool approximate)
      : SearchIndex(describe(params, approximate)), approximate_(approximate) {
    resolution_param_m_ = std::stod(info().params.at("resolution_m"));  // shortest round-trip text: lossless
    points_per_leaf_ = info().bucket->value;
  }

  // Nodes as PCL allocates them (one object per leaf and per branch, leaves holding a std::vector of
  // point indices), the indices themselves, and the PointCloud<PointXYZ> copy of the model PCL searches.
  std::size_t index_bytes() const override {
    if (!octree_) return 0;
    return octree_->getLeafCount() * sizeof(Octree::LeafNode) +
           octree_->getBranchCount() * sizeof(Octree::BranchNode) + model_size() * sizeof(pcl::index_t) +
           cloud_->size() * sizeof(pcl::PointXYZ);
  }

 private:
  static AdapterInfo describe(const Params& params, bool approximate) {
    AdapterInfo info;
    info.name = approximate ? "pcl_octree_approx" : "pcl_octree";
    info.concurrency = Concurrency::queries;
    info.library = "PCL";
    info.version = PCL_VERSION_PRETTY;
    info.structure = "octree";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = approximate ? Strategy::unsupported : Strategy::native;
    info.ranged = Strategy::via_knn;
    info.exact = !approximate;
    ParamReader reader(info.name, params);
    reader.get_double("resolution_m", 0.0, 0.0, 1e6);  // voxel edge; 0 = auto from leaf_points
    reader.get_bucket("leaf_points", 10, 1, 1000000, 1, 64);  // the paper's bucket size for synthetic data
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        approximate ? "approxNearestSearch: 1-NN only (k > 1 and radius refused), not exact; float coordinates "
                      "relative to the bounding-box centre, distance recomputed in double"
                    : "PCL keeps d^2 <= r^2 but prunes voxels by float centres (misses coincident points at r=0): "
                      "float coordinates relative to the model's bounding-box centre, radius searched wider by "
                      "1e-5 + 1e-6 of the coordinates, distances recomputed in double and cut at <= r; k-NN asks "
                      "k+1 and, when the (k+1)-th is within float error of the k-th, adds a radius search so "
                      "near-ties resolve as in double; resolution_m=0 picks voxels holding ~leaf_points points";
    return info;
  }

  void do_build(const Cloud& model) override {
    frame_.fit(model);
    const double resolution_m =
        resolution_param_m_ > 0.0 ? resolution_param_m_ : auto_resolution_m(model, points_per_leaf_);
    const double extent_m = (model.rowwise().maxCoeff() - model.rowwise().minCoeff()).maxCoeff();
    if (extent_m / resolution_m > 1e9) {  // PCL's octree keys have 32 bits per axis
      throw InputError(info().name + ": resolution_m " + std::to_string(resolution_m) + " is too fine for a cloud " +
                       std::to_string(extent_m) + " m wide");
    }
    if (notes_before_build_.empty()) notes_before_build_ = info().notes;
    mutable_info().notes = notes_before_build_ + "; voxel edge used " + std::to_string(resolution_m) + " m";
    cloud_ = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    cloud_->resize(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      (*cloud_)[static_cast<std::size_t>(i)] = to_pcl(frame_, model.col(i).data());
    }
    model_ = &model;
    octree_ = std::make_unique<Octree>(resolution_m);
    octree_->setInputCloud(cloud_);
    octree_->addPointsFromInputCloud();
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (approximate_) {
      if (k != 1) throw InputError(info().name + ": approxNearestSearch finds one neighbour only (k must be 1)");
      out.reset(n_queries, n_queries);
      for (Eigen::Index q = 0; q < queries.cols(); ++q) {
        pcl::index_t index = -1;
        float sq_dist = 0.0f;
        octree_->approxNearestSearch(to_pcl(frame_, queries.col(q).data()), index, sq_dist);
        if (index >= 0) out.push(static_cast<PointIndex>(index), 0.0);
        out.end_query();
      }
      recompute_sq_dists(*model_, queries, out);
      return;
    }
    pcl_exact_knn(*octree_, frame_, *model_, queries, k, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    pcl_exact_radius(*octree_, frame_, *model_, queries, radius_m, out);
  }

  bool approximate_;
  std::string notes_before_build_;
  double resolution_param_m_ = 0.0;
  double points_per_leaf_ = 10.0;
  FloatFrame frame_;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  const Cloud* model_ = nullptr;
  std::unique_ptr<Octree> octree_;  // PCL's k-NN and approximate search are non-const member functions
};

}  // namespace

std::unique_ptr<SearchIndex> make_pcl_octree(const Params& params) {
  return std::make_unique<PclOctree>(params, false);
}
std::unique_ptr<SearchIndex> make_pcl_octree_approx(const Params& params) {
  return std::make_unique<PclOctree>(params, true);
}

}  // namespace nnb::adapters
