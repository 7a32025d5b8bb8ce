// libspatialindex: an R-tree in main memory (MemoryStorageManager), one degenerate box per point, in
// the quadratic and the R* variant. Node capacity 10 as in the paper (the library's default of 100
// is meant for disk pages).
//
// Its k-NN search orders by plain (square-rooted) distances and returns every entry tied with the k-th,
// so it may return more than k: rows are recomputed in double and cut to the k nearest. It has no
// radius search: the query's bounding box is intersected, then filtered exactly.
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <spatialindex/SpatialIndex.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace nnb::adapters {
namespace {

namespace si = SpatialIndex;

// Collects the identifiers of the data entries the tree reports.
class IdCollector final : public si::IVisitor {
 public:
  explicit IdCollector(Neighbours& out) : out_(out) {}
  void visitNode(const si::INode&) override {}
  void visitData(const si::IData& data) override {
    out_.push(static_cast<PointIndex>(data.getIdentifier()), std::numeric_limits<double>::quiet_NaN());
  }
  void visitData(std::vector<const si::IData*>& entries) override {
    for (const auto* data : entries) visitData(*data);
  }

 private:
  Neighbours& out_;
};

// Runs a libspatialindex call and turns its exceptions (not std::exceptions) into ours: a rejected
// argument (e.g. a parameter combination it refuses) is bad input, anything else a runtime error.
template <class Call>
void guarded(const std::string& adapter, Call&& call) {
  try {
    call();
  } catch (Tools::IllegalArgumentException& e) {
    throw InputError(adapter + ": libspatialindex refused: " + e.what());
  } catch (Tools::Exception& e) {
    throw std::runtime_error(adapter + ": libspatialindex: " + e.what());
  }
}

// Bytes the memory storage manager holds for one serialised node and for one entry in it
// (RTree::Node::storeToByteArray: type, level and child count, the node's box; per entry a box, an id
// and a data length), plus the manager's per-node bookkeeping (an Entry object and its vector slot).
constexpr std::size_t kBoxBytes = 2 * 3 * sizeof(double);
constexpr std::size_t kNodeBytes = 3 * 4 + kBoxBytes + 16 + sizeof(void*);
constexpr std::size_t kEntryBytes = kBoxBytes + sizeof(si::id_type) + 4;

class SpatialIndexRTree final : public SearchIndex {
 public:
  SpatialIndexRTree(const Params& params, bool rstar) : SearchIndex(describe(params, rstar)), rstar_(rstar) {
    capacity_ = static_cast<std::uint32_t>(info().bucket->value);
    fill_factor_ = std::stod(info().params.at("fill_factor"));  // shortest round-trip text: lossless
  }

  ~SpatialIndexRTree() override {
    tree_.reset();  // the tree writes to the storage manager: destroy it first
    storage_.reset();
  }

  std::size_t index_bytes() const override { return index_bytes_; }

 private:
  static AdapterInfo describe(const Params& params, bool rstar) {
    AdapterInfo info;
    info.name = rstar ? "spatialindex_rstar" : "spatialindex_quadratic";
    info.library = "libspatialindex";
    info.version = std::to_string(SIDX_VERSION_MAJOR) + "." + std::to_string(SIDX_VERSION_MINOR) + "." +
                   std::to_string(SIDX_VERSION_REV);
    info.structure = rstar ? "R*-tree" : "R-tree (quadratic split)";
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::via_box;
    info.ranged = Strategy::via_knn;
    ParamReader reader(info.name, params);
    reader.get_bucket("capacity", 10, 4, 1 << 16, 4, 128);  // the library needs >= 4
    // The library rejects fill factors >= 0.5 for the quadratic split.
    reader.get_double("fill_factor", rstar ? 0.7 : 0.4, 0.01, rstar ? 0.99 : 0.49);
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "k-NN rows recomputed in double and cut to k (the library returns all ties at the k-th "
        "distance, ordered by sqrt distance); radius = intersectsWithQuery on the query's box widened "
        "by rounding margins, then sq_dist <= r*r";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    storage_.reset();
    model_ = &model;
    guarded(info().name, [&] {
      storage_.reset(si::StorageManager::createNewMemoryStorageManager());
      si::id_type index_id = 0;
      tree_.reset(si::RTree::createNewRTree(*storage_, fill_factor_, capacity_, capacity_, 3,
                                            rstar_ ? si::RTree::RV_RSTAR : si::RTree::RV_QUADRATIC, index_id));
      for (Eigen::Index i = 0; i < model.cols(); ++i) {
        tree_->insertData(0, nullptr, si::Point(model.col(i).data(), 3), static_cast<si::id_type>(i));
      }
      si::IStatistics* raw = nullptr;
      tree_->getStatistics(&raw);
      const std::unique_ptr<si::IStatistics> stats(raw);
      const std::size_t nodes = stats->getNumberOfNodes();
      const std::size_t entries = static_cast<std::size_t>(stats->getNumberOfData()) + nodes - 1;
      index_bytes_ = nodes * kNodeBytes + entries * kEntryBytes;
    });
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(k) * queries.cols());
    IdCollector collect(out);
    guarded(info().name, [&] {
      for (Eigen::Index q = 0; q < queries.cols(); ++q) {
        tree_->nearestNeighborQuery(static_cast<std::uint32_t>(k), si::Point(queries.col(q).data(), 3), collect);
        out.end_query();
      }
    });
    recompute_sq_dists(*model_, queries, out);
    sort_and_truncate(static_cast<std::size_t>(k), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    IdCollector collect(out);
    // Wide enough for any point whose rounded squared distance is <= r*r; one ulp outwards per bound
    // makes up for the rounding of query +- half_width.
    const double half_width_m = radius_m * (1.0 + 1e-12);
    guarded(info().name, [&] {
      double low[3];
      double high[3];
      for (Eigen::Index q = 0; q < queries.cols(); ++q) {
        for (int d = 0; d < 3; ++d) {
          low[d] = next_down(queries(d, q) - half_width_m);
          high[d] = next_up(queries(d, q) + half_width_m);
        }
        tree_->intersectsWithQuery(si::Region(low, high, 3), collect);
        out.end_query();
      }
    });
    recompute_sq_dists(*model_, queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  bool rstar_;
  std::uint32_t capacity_ = 10;
  double fill_factor_ = 0.4;
  const Cloud* model_ = nullptr;
  std::unique_ptr<si::IStorageManager> storage_;
  std::unique_ptr<si::ISpatialIndex> tree_;
  std::size_t index_bytes_ = 0;
};

}  // namespace

std::unique_ptr<SearchIndex> make_spatialindex_quadratic(const Params& params) {
  return std::make_unique<SpatialIndexRTree>(params, false);
}

std::unique_ptr<SearchIndex> make_spatialindex_rstar(const Params& params) {
  return std::make_unique<SpatialIndexRTree>(params, true);
}

}  // namespace nnb::adapters
