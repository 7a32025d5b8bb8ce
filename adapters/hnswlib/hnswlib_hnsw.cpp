// hnswlib's HierarchicalNSW (the header-only reference implementation of Malkov and Yashunin's hierarchical
// navigable small-world graphs): a graph searched greedily from a top layer down, approximate by design. Float
// points (L2Space: squared L2 in float), k-NN only: ranged via k-NN, no radius search. Each point is inserted
// with its model index as its label, one after another, so a build gives the same graph every time.
//
// The library's own defaults: M = 16 links a node (32 on the bottom layer), ef_construction = 200, and a search
// list of ef = 10 (the library raises it to k when k is larger).
//
// Without its SSE prefetches: 0.6.2's prefetch reads the link after the last of a full upper-layer list, past
// the end of its allocation (ASan: heap-buffer-overflow in searchBaseLayer). For 3-D points its distance is the
// plain loop either way (it vectorises dimensions in multiples of 4), so the prefetches are all this removes
// (results/ab/hnswlib/prefetch_probe.txt).
#define NO_MANUAL_VECTORIZATION
#include <hnswlib/hnswlib.h>

#include "../float_libs/float_frame.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using Graph = hnswlib::HierarchicalNSW<float>;

class HnswIndex final : public SearchIndex {
 public:
  explicit HnswIndex(const Params& params) : SearchIndex(describe(params)) {}

  // The graph's memory as the library allocates it: every node's bottom layer (links, float point, label),
  // the upper layers' links, a lock and a level a node, the label map's nodes and one visited list.
  std::size_t index_bytes() const override {
    if (!graph_) return 0;
    const Graph& g = *graph_;
    std::size_t upper_links = 0;
    for (std::size_t i = 0; i < g.cur_element_count; ++i) {
      upper_links += static_cast<std::size_t>(g.element_levels_[i]) * g.size_links_per_element_;
    }
    constexpr std::size_t kMapNodeBytes = sizeof(void*) + sizeof(std::pair<hnswlib::labeltype, hnswlib::tableint>);
    return g.max_elements_ * (g.size_data_per_element_ + sizeof(char*) + sizeof(int) + sizeof(std::mutex) +
                              sizeof(hnswlib::vl_type)) +
           upper_links + g.label_lookup_.size() * kMapNodeBytes + g.label_lookup_.bucket_count() * sizeof(void*);
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "hnswlib_hnsw";
    info.library = "hnswlib";
    info.version = NNB_HNSWLIB_VERSION;
    info.structure = "hierarchical navigable small-world graph";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::unsupported;
    info.ranged = Strategy::via_knn;
    info.exact = false;
    info.concurrency = Concurrency::queries;  // searchKnn is const; visited lists come from a locked pool
    ParamReader reader(info.name, params);
    reader.get_int("M", 16, 2, 10000);
    reader.get_int("ef_construction", 200, 1, 1 << 20);
    reader.get_int("ef", 10, 1, 1 << 20);
    info.params = reader.finish();
    info.notes =
        "approximate; float (L2Space over coordinates relative to the model's bounding-box centre), rows "
        "recomputed and sorted in double; points inserted in model order on one thread, labels = model "
        "indices; ef set once after the build (the library searches max(ef, k)); no radius search; built "
        "with NO_MANUAL_VECTORIZATION (its SSE prefetch reads past a link list; 3-D distances are scalar anyway)";
    return info;
  }

  void do_build(const Cloud& model) override {
    frame_.fit(model);
    model_ = &model;
    const auto n = static_cast<std::size_t>(model.cols());
    const Params& p = info().params;
    graph_.reset();
    graph_ = std::make_unique<Graph>(&space_, n, std::stoul(p.at("M")), std::stoul(p.at("ef_construction")));
    for (std::size_t i = 0; i < n; ++i) {  // the graph keeps its own copy of each point
      const double* point = model.col(static_cast<Eigen::Index>(i)).data();
      const float xyz[3] = {frame_.coord(point, 0), frame_.coord(point, 1), frame_.coord(point, 2)};
      graph_->addPoint(xyz, i);
    }
    graph_->setEf(std::stoul(p.at("ef")));
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const auto k_rows = static_cast<std::size_t>(k);
    out.reset(n_queries, n_queries * k_rows);
    std::vector<std::pair<double, PointIndex>> row;
    for (std::size_t q = 0; q < n_queries; ++q) {
      const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
      const float probe[3] = {frame_.coord(query, 0), frame_.coord(query, 1), frame_.coord(query, 2)};
      auto found = graph_->searchKnn(probe, k_rows);
      row.clear();
      for (; !found.empty(); found.pop()) {
        const auto index = static_cast<PointIndex>(found.top().second);
        row.emplace_back(sq_dist_m2(query, model_->col(index).data()), index);
      }
      std::sort(row.begin(), row.end());
      for (const auto& [sq_m2, index] : row) out.push(index, sq_m2);
      out.end_query();
    }
  }

  FloatFrame frame_;
  const Cloud* model_ = nullptr;
  hnswlib::L2Space space_{3};
  std::unique_ptr<Graph> graph_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_hnswlib_hnsw(const Params& params) {
  return std::make_unique<HnswIndex>(params);
}

}  // namespace nnb::adapters
