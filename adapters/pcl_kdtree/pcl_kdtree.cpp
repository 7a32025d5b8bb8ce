// PCL's k-d tree, pcl::KdTreeFLANN<PointXYZ>: FLANN's KDTreeSingleIndex inside, leaf size fixed at 15 by
// PCL, float. One query at a time (PCL has no batch call); ranged search is radiusSearch with max_nn, which
// PCL passes on to FLANN as max_neighbors (the k nearest within the radius, pruned).
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/pcl_config.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "../float_libs/pcl_search.hpp"
#include "nnb/registry.hpp"

#include <memory>
#include <vector>

namespace nnb::adapters {
namespace {

class PclKdTree final : public SearchIndex {
 public:
  explicit PclKdTree(const Params& params) : SearchIndex(describe(params)) {}

  // PCL keeps: our PointCloud<PointXYZ> (16 bytes a point), its own float array of the points (12) and an
  // index map (4); FLANN inside keeps a reordered float copy (12), a row pointer per point (8), and its
  // permutation plus node pool, which FLANN's usedMemory() puts at 13.4 bytes a point for 15-point leaves
  // (measured on 300k uniform points; PCL hides the index, so the figure is not read at run time).
  std::size_t index_bytes() const override {
    return model_size() * (16 + 12 + 4 + 12 + 8) + model_size() * 134 / 10;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "pcl_kdtree";
    info.concurrency = Concurrency::queries;
    info.library = "PCL";
    info.version = PCL_VERSION_PRETTY;
    info.structure = "k-d tree (FLANN, 15 points a leaf)";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    info.exact = true;
    info.params = ParamReader(info.name, params).finish();  // PCL fixes the leaf size at 15
    info.notes =
        "PCL's FLANN keeps d^2 < r^2 in float (drops points at r, finds nothing at r=0): float coordinates "
        "relative to the model's bounding-box centre, radius searched wider by 1e-5 + 1e-6 of the coordinates, "
        "distances recomputed in double and cut at <= r; k-NN asks k+1 and, when the (k+1)-th is within float error of "
        "the k-th, adds a radius search so near-ties resolve as in double; ranged = radiusSearch with max_nn = k+1, "
        "made exact the same way";
    return info;
  }

  void do_build(const Cloud& model) override {
    frame_.fit(model);
    cloud_ = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    cloud_->resize(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      (*cloud_)[static_cast<std::size_t>(i)] = to_pcl(frame_, model.col(i).data());
    }
    model_ = &model;
    tree_ = std::make_unique<pcl::KdTreeFLANN<pcl::PointXYZ>>(/*sorted=*/false);
    tree_->setInputCloud(cloud_);
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    pcl_exact_knn(*tree_, frame_, *model_, queries, k, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    pcl_exact_radius(*tree_, frame_, *model_, queries, radius_m, out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    pcl_exact_ranged(*tree_, frame_, *model_, queries, k, max_dist_m, out);
  }

  FloatFrame frame_;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  const Cloud* model_ = nullptr;
  std::unique_ptr<pcl::KdTreeFLANN<pcl::PointXYZ>> tree_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_pcl_kdtree(const Params& params) {
  return std::make_unique<PclKdTree>(params);
}

}  // namespace nnb::adapters
