// ITK's k-d tree (itk::Statistics::KdTree, made by KdTreeGenerator): the tree itk::PointsLocator builds and
// ITK's point-set registration metrics search, over a VectorContainer of itk::Point<double, 3>. Its k-NN and
// radius searches are its own; it has no ranged search (via k-NN by default, or via radius).
//
// Its distances are square roots (EuclideanDistanceMetric), compared with the squared offsets of a node's box
// after squaring them again: made exact as the other square-rooting libraries are (sqrt_libs/exact_sqrt.hpp).
#include <itkConfigure.h>
#include <itkKdTree.h>
#include <itkKdTreeGenerator.h>
#include <itkPoint.h>
#include <itkVectorContainer.h>
#include <itkVectorContainerToListSampleAdaptor.h>

#include "../sqrt_libs/exact_sqrt.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

using ItkPoint = itk::Point<double, 3>;
using Points = itk::VectorContainer<itk::IdentifierType, ItkPoint>;
using Sample = itk::Statistics::VectorContainerToListSampleAdaptor<Points>;
using Generator = itk::Statistics::KdTreeGenerator<Sample>;
using Tree = Generator::KdTreeType;
using TreeNode = Tree::KdTreeNodeType;
using Ids = Tree::InstanceIdentifierVectorType;

// The bytes of the nodes under node: an inner node holds its split and one point's identifier, a leaf the
// identifiers of its points (the tree's one shared empty leaf is not counted).
std::size_t node_bytes(const TreeNode* node, const TreeNode* shared_empty) {
  if (node == nullptr || node == shared_empty) return 0;
  if (node->IsTerminal()) {
    return sizeof(itk::Statistics::KdTreeTerminalNode<Sample>) + node->Size() * sizeof(Tree::InstanceIdentifier);
  }
  return sizeof(itk::Statistics::KdTreeNonterminalNode<Sample>) + node_bytes(node->Left(), shared_empty) +
         node_bytes(node->Right(), shared_empty);
}

// A radius for the tree's radius search. It skips a subtree unless the squared distance to its box is below the
// squared radius, strictly: a radius whose square rounds to 0 would skip points at distance 0 beyond a split.
double squarable_m(double radius_m) {
  static const double kSmallestSquarable_m = std::sqrt(std::numeric_limits<double>::min());
  return std::max(radius_m, kSmallestSquarable_m);
}

class ItkKdTreeIndex final : public SearchIndex {
 public:
  explicit ItkKdTreeIndex(const Params& params) : SearchIndex(describe(params)) {}

  // The points' copy the sample adaptor reads, and the tree's nodes.
  std::size_t index_bytes() const override {
    return points_ ? points_->Size() * sizeof(ItkPoint) + tree_bytes_ : 0;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "itk_kdtree";
    info.library = "ITK";
    info.version = std::string(ITK_VERSION_STRING) + "." + std::to_string(ITK_VERSION_PATCH);
    info.structure = "k-d tree";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::via_knn;
    info.concurrency = Concurrency::queries;  // Search is const and keeps its state on the stack
    ParamReader reader(info.name, params);
    reader.get_bucket("bucket_size", 16, 1, 1 << 20, 1, 64);  // what PointsLocator sets
    info.bucket = reader.bucket();
    info.params = reader.finish();
    info.notes =
        "sqrt distances: limits widened by 1e-12 of (query to model centre + model diameter), distances "
        "recomputed in double and cut at <= r; k-NN asks k+1 and, when the k-th and next are within that "
        "margin, takes every point within the k-th distance and cuts to k; radii handed to the tree are at "
        "least sqrt(DBL_MIN) (it prunes strictly on squares); the generator is released after the build, the "
        "tree and the points kept";
    return info;
  }

  void do_build(const Cloud& model) override {
    points_ = Points::New();
    auto& points = points_->CastToSTLContainer();
    points.resize(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      for (int d = 0; d < 3; ++d) points[static_cast<std::size_t>(i)][d] = model(d, i);
    }
    sample_ = Sample::New();
    sample_->SetVectorContainer(points_);
    sample_->SetMeasurementVectorSize(3);
    const auto generator = Generator::New();
    generator->SetSample(sample_);
    generator->SetBucketSize(static_cast<unsigned>(info().bucket->value));
    generator->Update();
    tree_ = generator->GetOutput();
    tree_bytes_ = node_bytes(tree_->GetRoot(), tree_->GetEmptyTerminalNode());
    margin_.fit(model);
  }

  static ItkPoint probe_of(const double* query) {
    ItkPoint probe;
    for (int d = 0; d < 3; ++d) probe[d] = query[d];
    return probe;
  }

  // The found points within search_m as (squared distance, index), sorted as brute force sorts them.
  void sorted_rows(const double* query, const Ids& ids, double search_m, std::vector<SqrtCandidate>& rows) const {
    const double limit_sq_m2 = search_m * search_m;
    rows.clear();
    for (const auto id : ids) {
      const double sq_m2 = sq_dist_m2(query, points_->ElementAt(id).GetDataPointer());
      if (sq_m2 <= limit_sq_m2) rows.emplace_back(sq_m2, static_cast<PointIndex>(id));
    }
    std::sort(rows.begin(), rows.end());
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const std::size_t n_points = points_->Size();
    const auto k_rows = static_cast<std::size_t>(k);
    out.reset(n_queries, n_queries * k_rows);
    Ids ids;
    std::vector<double> sqrt_dists;
    std::vector<SqrtCandidate> rows;
    const double unlimited_m = std::numeric_limits<double>::infinity();
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const ItkPoint probe = probe_of(query);
      const auto nearest = [&](std::size_t n, double search_m, std::vector<SqrtCandidate>& found) {
        tree_->Search(probe, static_cast<unsigned>(n), ids, sqrt_dists);
        sorted_rows(query, ids, search_m, found);
      };
      const auto within = [&](double search_m, std::vector<SqrtCandidate>& found) {
        tree_->Search(probe, squarable_m(search_m), ids);
        sorted_rows(query, ids, search_m, found);
      };
      exact_nearest_rows(query, k_rows, unlimited_m, n_points, margin_, nearest, within, rows);
      append_row(rows, k_rows, unlimited_m * unlimited_m, out);  // a squared limit, in m^2
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    const double limit_sq_m2 = radius_m * radius_m;
    Ids ids;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      tree_->Search(probe_of(query), squarable_m(margin_.widened_m(radius_m, query)), ids);
      for (const auto id : ids) {
        const double sq_m2 = sq_dist_m2(query, points_->ElementAt(id).GetDataPointer());
        if (sq_m2 <= limit_sq_m2) out.push(static_cast<PointIndex>(id), sq_m2);
      }
      out.end_query();
    }
  }

  Points::Pointer points_;
  Sample::Pointer sample_;
  Tree::Pointer tree_;
  std::size_t tree_bytes_ = 0;
  SqrtMargin margin_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_itk_kdtree(const Params& params) {
  return std::make_unique<ItkKdTreeIndex>(params);
}

}  // namespace nnb::adapters
