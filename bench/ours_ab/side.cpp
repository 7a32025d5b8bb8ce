// One side of scripts/ours_ab.sh: ours' trees from one revision of ours/include, compiled into a shared
// object of its own (hidden symbols, loaded RTLD_LOCAL), so that two revisions live in one process. The
// driver (ours_ab.cpp) sees only the C functions at the end. A batch is answered as the adapters' "auto"
// order does: the first kProbe queries in the caller's order; the rest too when most of those followed the
// previous query closely (a scan), else in Morton order, each answer stored at its query's place.
#include "ours/kdtree.hpp"
#include "ours/octree.hpp"
#include "ours/query_order.hpp"

#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#define OURS_AB_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

constexpr std::size_t kProbe = 256;

struct Index {
  virtual ~Index() = default;
  // sq_out[i]: query i's nearest squared distance within the limit (m^2), -1 when it has none.
  virtual void answer(const double* xyz, std::size_t n, double limit_sq_m2, double* sq_out) = 0;
};

template <class Tree>
class TreeIndex : public Index {
 public:
  explicit TreeIndex(std::unique_ptr<Tree> tree) : tree_(std::move(tree)) {}

  void answer(const double* xyz, std::size_t n, double limit_sq_m2, double* sq_out) override {
    const std::size_t probe = std::min(n, kProbe);
    const std::size_t close = search(xyz, probe, limit_sq_m2, sq_out, nullptr);
    const std::size_t rest = n - probe;
    if (2 * close >= probe) {
      search(xyz + 3 * probe, rest, limit_sq_m2, sq_out + probe, nullptr);
      return;
    }
    ours::morton_order(xyz + 3 * probe, rest, order_);
    sorted_.resize(3 * rest);
    for (std::size_t s = 0; s < rest; ++s) std::memcpy(&sorted_[3 * s], xyz + 3 * (probe + order_.order[s]), 24);
    search(sorted_.data(), rest, limit_sq_m2, sq_out + probe, order_.order.data());
  }

 private:
  // Ranged 1-NN of the n queries at xyz; query s's answer goes to out[place[s]] (out[s] without places).
  std::size_t search(const double* xyz, std::size_t n, double limit_sq_m2, double* out, const std::uint32_t* place) {
    return tree_->knn_batch(xyz, n, 1, limit_sq_m2, buffers_, [&](std::size_t s, const auto& best) {
      out[place ? place[s] : s] = best.empty() ? -1.0 : double(best[0].sq_dist);
    });
  }

  std::unique_ptr<Tree> tree_;
  typename Tree::Buffers buffers_;
  ours::QueryOrder order_;
  std::vector<double> sorted_;
};

// The trees at the adapters' defaults (ours_kdtree: buckets of 64; ours_octree: 80 points a leaf).
Index* build(const std::string& tree, const double* xyz, std::size_t n) {
  if (tree == "kdtree") {
    auto t = std::make_unique<ours::KdTree<double>>();
    t->build(xyz, n, 64);
    return new TreeIndex<ours::KdTree<double>>(std::move(t));
  }
  if (tree == "octree") {
    auto t = std::make_unique<ours::Octree<double>>();
    t->build(xyz, n, 80, 0.0);
    return new TreeIndex<ours::Octree<double>>(std::move(t));
  }
  return nullptr;
}

}  // namespace

/// Builds "kdtree" or "octree" over n points (x,y,z triples, metres); null for another name or a failed build.
OURS_AB_EXPORT void* ours_ab_build(const char* tree, const double* xyz, std::size_t n) {
  try {
    return build(tree, xyz, n);
  } catch (const std::exception&) {
    return nullptr;
  }
}

/// Ranged 1-NN within max_dist_m of each of n queries: sq_out[i] = its nearest squared distance (m^2), -1 for
/// none. Returns 0, or 1 when the search threw (out of memory).
OURS_AB_EXPORT int ours_ab_answer(void* index, const double* xyz, std::size_t n, double max_dist_m, double* sq_out) {
  try {
    static_cast<Index*>(index)->answer(xyz, n, max_dist_m * max_dist_m, sq_out);
    return 0;
  } catch (const std::exception&) {
    return 1;
  }
}

OURS_AB_EXPORT void ours_ab_free(void* index) { delete static_cast<Index*>(index); }
