// Our compact octree (ours/octree.hpp, after 3DTK): 8-byte nodes with child bitmasks, leaves holding
// their points together, integer descent to the node holding the query's box (Algorithms 1 and 2).
#include "nnb/registry.hpp"
#include "ours/octree.hpp"
#include "ours_rows.hpp"

namespace nnb::adapters {
namespace {

// Measured on both pairs of bench/micro_nns: 64 is the fastest at 0.02 m, 96-128 at 0.3-1 m; 80 keeps
// every distance within 1.2x of the k-d tree.
constexpr int kDefaultMaxPoints = 80;

class OursOctree final : public ours_rows::OursIndex<ours::Octree> {
 public:
  explicit OursOctree(const Params& params)
      : OursIndex(describe(params)),
        max_points_(info().bucket->value),
        min_cell_m_(std::stod(info().params.at("min_cell_size_m"))) {}  // shortest round-trip text: lossless

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "ours_octree";
    info.concurrency = Concurrency::queries;
    info.library = "ours (this project, after 3DTK)";
    info.version = "1";
    info.structure = "octree";
    ParamReader reader(info.name, params);
    reader.get_bucket("max_points_per_leaf", kDefaultMaxPoints, 1, 1 << 20, 8, 256);
    reader.get_double("min_cell_size_m", 0.0, 0.0, 1e9);
    return shared_info(std::move(info), reader);
  }

  void do_build(const Cloud& model) override {
    build_tree(model, [&](auto& tree, const double* xyz, std::size_t n) { tree.build(xyz, n, max_points_, min_cell_m_); });
  }

  int max_points_ = kDefaultMaxPoints;
  double min_cell_m_ = 0;
};

}  // namespace

std::unique_ptr<SearchIndex> make_ours_octree(const Params& params) { return std::make_unique<OursOctree>(params); }

}  // namespace nnb::adapters
