// VTK's tree point locators, vtkKdTreePointLocator (a vtkKdTree split at medians) and vtkOctreePointLocator.
// Both search a float copy of the points (LocatorPoints): they are treated as the other float libraries
// are (adapters/float_libs): float coordinates relative to the model's bounding-box centre, a wider float
// search, distances recomputed in double; k-NN asks for k+1 and resolves near-ties by a radius search.
//
// k-NN is FindClosestNPoints (sorted, float distances), radius FindPointsWithinRadius (inclusive, double
// distances to the float points). Ranged search is k-NN cut at the limit: FindClosestPointWithinRadius
// (the 1-NN within a radius) cannot be made exact here. It keeps one float candidate, so near-ties stay
// unresolved; each leaf's scan starts from 4 x (widest side of the model)^2, so for a query farther than
// twice the model's width the k-d tree found nothing (and nothing anywhere for a one-point model) and the
// octree returned an arbitrary point (the first of a leaf); and its strict test misses coincident points
// at radius 0.
#include "../float_libs/exact_knn.hpp"
#include "../float_libs/float_frame.hpp"
#include "nnb/registry.hpp"
#include "vtk_common.hpp"

#include <vtkFloatArray.h>
#include <vtkIdList.h>
#include <vtkKdNode.h>
#include <vtkKdTree.h>
#include <vtkKdTreePointLocator.h>
#include <vtkOctreePointLocator.h>
#include <vtkOctreePointLocatorNode.h>
#include <vtkPointSet.h>
#include <vtkSmartPointer.h>

#include <cstddef>
#include <memory>
#include <vector>

namespace nnb::adapters {
namespace {

using vtk::build_single_threaded;
using vtk::point_set;

// vtkKdTreePointLocator whose tree gets a leaf size: the locator builds its vtkKdTree itself, with the
// tree's default MinCells and no way to change it, so BuildLocator is vtkKdTreePointLocator's own with
// SetMinCells added.
class SizedKdTreeLocator final : public vtkKdTreePointLocator {
 public:
  static SizedKdTreeLocator* New() { return vtk::new_vtk_object<SizedKdTreeLocator>(); }
  void set_min_cells(int min_cells) { min_cells_ = min_cells; }

  void BuildLocator() override {
    if (KdTree) return;
    vtkPointSet* points = vtkPointSet::SafeDownCast(GetDataSet());
    if (!points) return;
    KdTree = vtkKdTree::New();
    KdTree->SetMinCells(min_cells_);
    KdTree->BuildLocatorFromPoints(points);
    KdTree->GetBounds(Bounds);
    Modified();
  }

  /// Bytes of the tree: its float points and int ids, the nodes (a binary tree over the regions) and the
  /// per-region arrays (region list, point offsets).
  std::size_t tree_bytes(std::size_t n_points) const {
    if (!KdTree) return 0;
    const auto regions = static_cast<std::size_t>(KdTree->GetNumberOfRegions());
    return n_points * (3 * sizeof(float) + sizeof(int)) + (2 * regions - 1) * sizeof(vtkKdNode) +
           regions * (sizeof(vtkKdNode*) + sizeof(int));
  }

 private:
  int min_cells_ = 100;
};

struct KdTree {
  using Locator = SizedKdTreeLocator;
  static constexpr const char* name = "vtk_kdtree";
  static constexpr const char* structure = "k-d tree";
  static constexpr const char* bucket_name = "min_cells";  // vtkKdTree::MinCells, points per region
  static constexpr int default_bucket = 100;               // vtkKdTree's constructor
  static constexpr const char* bucket_note =
      "min_cells is vtkKdTree's MinCells (a region is split while both halves keep at least that many points; "
      "at most 20 levels), set by overriding vtkKdTreePointLocator::BuildLocator, which offers no setter";
  static void configure(Locator& locator, int bucket) { locator.set_min_cells(bucket); }
  static std::size_t bytes(const Locator& locator, std::size_t n_points) { return locator.tree_bytes(n_points); }
};

struct Octree {
  using Locator = vtkOctreePointLocator;
  static constexpr const char* name = "vtk_octree";
  static constexpr const char* structure = "octree";
  static constexpr const char* bucket_name = "max_points_per_region";  // vtkOctreePointLocator's setting
  static constexpr int default_bucket = 100;                            // its constructor
  static constexpr const char* bucket_note =
      "max_points_per_region is MaximumPointsPerRegion (octants split above it, at most 20 levels), cubic octants";
  static void configure(Locator& locator, int bucket) { locator.SetMaximumPointsPerRegion(bucket); }
  // Float points and int ids, the leaf list, and the nodes: each split makes 8 children, so a tree of L
  // leaves has (L - 1) / 7 inner nodes.
  static std::size_t bytes(Locator& locator, std::size_t n_points) {
    const auto leaves = static_cast<std::size_t>(locator.GetNumberOfLeafNodes());
    const std::size_t nodes = leaves + (leaves - 1) / 7;
    return n_points * (3 * sizeof(float) + sizeof(int)) + leaves * sizeof(vtkOctreePointLocatorNode*) +
           nodes * sizeof(vtkOctreePointLocatorNode);
  }
};

template <class Variant>
class VtkTree final : public SearchIndex {
 public:
  explicit VtkTree(const Params& params) : SearchIndex(describe(params)) { bucket_ = info().bucket->value; }

  // The tree's own float copy and nodes, plus the float model in the centred frame that VTK builds from.
  std::size_t index_bytes() const override {
    if (!locator_) return 0;
    return Variant::bytes(*locator_, model_size()) + points_.size() * sizeof(float);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = Variant::name;
    info.library = "VTK";
    info.version = vtk::vtk_version();
    info.structure = Variant::structure;
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    ParamReader reader(info.name, params);
    reader.get_bucket(Variant::bucket_name, Variant::default_bucket, 1, 1 << 20, 4, 256);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        std::string("VTK searches a float copy of the points (gave the wrong nearest point on near-ties): float "
                    "coordinates relative to the model's bounding-box centre, radius searched wider by 1e-5 + "
                    "1e-6 of the coordinates, distances recomputed in double and cut at <= r; k-NN asks k+1 and "
                    "adds a radius search on near-ties; ranged via k-NN, since FindClosestPointWithinRadius "
                    "answers wrongly beyond twice the model's width (k-d tree: nothing, octree: an arbitrary "
                    "point), misses coincident points at r=0 and keeps one float candidate; BuildLocator in "
                    "build(), on one thread; ") +
        Variant::bucket_note;
    return info;
  }

  void do_build(const Cloud& model) override {
    model_ = &model;
    frame_.fit(model);
    const auto n = static_cast<std::size_t>(model.cols());
    points_.resize(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) points_[3 * i + d] = frame_.coord(model.col(static_cast<Eigen::Index>(i)).data(), d);
    }
    coords_ = vtkSmartPointer<vtkFloatArray>::New();
    coords_->SetNumberOfComponents(3);
    coords_->SetArray(points_.data(), static_cast<vtkIdType>(points_.size()), 1);  // save = 1: ours to free
    data_ = point_set(coords_);
    locator_ = vtkSmartPointer<typename Variant::Locator>::New();
    Variant::configure(*locator_, bucket_);
    locator_->SetDataSet(data_);
    build_single_threaded([&] { locator_->BuildLocator(); });
  }

  /// Query column q in the model's float frame, as VTK takes it (double).
  void frame_query(const Cloud& queries, std::size_t q, double query_f[3]) const {
    const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
    for (int d = 0; d < 3; ++d) query_f[d] = frame_.coord(query, d);
  }

  // VTK's float squared distance, computed as FindClosestNPoints computes it.
  float float_sq_dist_m2(const double query_f[3], vtkIdType index) const {
    const float* point = &points_[3 * static_cast<std::size_t>(index)];
    const float dx = static_cast<float>(query_f[0]) - point[0];
    const float dy = static_cast<float>(query_f[1]) - point[1];
    const float dz = static_cast<float>(query_f[2]) - point[2];
    return dx * dx + dy * dy + dz * dz;
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    auto ids = vtkSmartPointer<vtkIdList>::New();
    double query_f[3];
    const auto knn_row = [&](std::size_t q, std::size_t n, FloatCandidates& row) {
      frame_query(queries, q, query_f);
      locator_->FindClosestNPoints(static_cast<int>(n), query_f, ids);
      row.indices.clear();
      row.sq_dists_m2.clear();
      for (vtkIdType i = 0; i < ids->GetNumberOfIds(); ++i) {
        row.indices.push_back(static_cast<PointIndex>(ids->GetId(i)));
        row.sq_dists_m2.push_back(float_sq_dist_m2(query_f, ids->GetId(i)));
      }
    };
    const auto radius_row = [&](std::size_t q, double search_m, std::vector<PointIndex>& row) {
      frame_query(queries, q, query_f);
      locator_->FindPointsWithinRadius(search_m, query_f, ids);
      row.clear();
      for (vtkIdType i = 0; i < ids->GetNumberOfIds(); ++i) row.push_back(static_cast<PointIndex>(ids->GetId(i)));
    };
    exact_knn(*model_, queries, static_cast<std::size_t>(k), frame_, knn_row, radius_row, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    auto ids = vtkSmartPointer<vtkIdList>::New();
    double query_f[3];
    for (std::size_t q = 0; q < n_queries; ++q) {
      frame_query(queries, q, query_f);
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      locator_->FindPointsWithinRadius(frame_.search_radius_m(query, radius_m), query_f, ids);
      for (vtkIdType i = 0; i < ids->GetNumberOfIds(); ++i) out.push(static_cast<PointIndex>(ids->GetId(i)), 0.0);
      out.end_query();
    }
    recompute_sq_dists(*model_, queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  int bucket_ = 100;
  const Cloud* model_ = nullptr;
  FloatFrame frame_;
  std::vector<float> points_;  // the model in float, centred, x y z per point: the data set VTK builds from
  vtkSmartPointer<vtkFloatArray> coords_;
  vtkSmartPointer<vtkPolyData> data_;
  vtkSmartPointer<typename Variant::Locator> locator_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_vtk_kdtree(const Params& params) {
  return std::make_unique<VtkTree<KdTree>>(params);
}

std::unique_ptr<SearchIndex> make_vtk_octree(const Params& params) {
  return std::make_unique<VtkTree<Octree>>(params);
}

}  // namespace nnb::adapters
