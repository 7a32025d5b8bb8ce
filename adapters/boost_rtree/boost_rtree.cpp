// Boost.Geometry's R-tree (bgi::rtree) over 3D double points, in its linear, quadratic and R* variants,
// with the run-time parameter types (dynamic_linear, ...) so that the node capacity is an adapter
// parameter. Built by the packing constructor (bulk loading) or by one insert per point.
//
// bgi::nearest returns the k nearest in no particular order and an arbitrary subset of the points tied
// with the k-th: one more than k is asked for, and where the last two may tie, every point within the
// k-th distance is fetched through its box and cut exactly. Radius search is a box intersection (the
// library's boxes include their faces) followed by the exact filter.
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

// Boost 1.74's rtree includes headers of its own that it marks deprecated (a message on every build).
#define BOOST_ALLOW_DEPRECATED_HEADERS
#include <boost/geometry.hpp>  // the rtree needs the cartesian distance strategies too
#include <boost/geometry/index/detail/rtree/utilities/view.hpp>
#include <boost/geometry/index/rtree.hpp>
#include <boost/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

namespace bg = boost::geometry;
namespace bgi = boost::geometry::index;

using BoostPoint = bg::model::point<double, 3, bg::cs::cartesian>;
using BoostBox = bg::model::box<BoostPoint>;
using Value = std::pair<BoostPoint, PointIndex>;
using Candidate = std::pair<double, PointIndex>;  // (squared distance, index): brute force's order

// Relative margin of the query boxes: far above the rounding of query +- half width and of a square root.
constexpr double kBoxPad = 1e-12;
// Boost's own squared distances may differ from ours by a few ulps: a gap narrower than this between
// the k-th and the next distance is treated as a possible tie.
constexpr double kTieMargin = 1e-12;

std::string boost_version() {
  return std::to_string(BOOST_VERSION / 100000) + "." + std::to_string(BOOST_VERSION / 100 % 1000) + "." +
         std::to_string(BOOST_VERSION % 100);
}

BoostPoint to_point(const double* xyz) { return BoostPoint(xyz[0], xyz[1], xyz[2]); }

// The box around the ball of radius_m, wide enough for every point whose squared distance rounds to at
// most radius_m^2 (one ulp outwards per bound for the rounding of centre +- half width).
BoostBox ball_box(const double* centre, double radius_m) {
  const double half_width_m = radius_m * (1.0 + kBoxPad);
  BoostPoint low;
  BoostPoint high;
  bg::set<0>(low, next_down(centre[0] - half_width_m));
  bg::set<1>(low, next_down(centre[1] - half_width_m));
  bg::set<2>(low, next_down(centre[2] - half_width_m));
  bg::set<0>(high, next_up(centre[0] + half_width_m));
  bg::set<1>(high, next_up(centre[1] + half_width_m));
  bg::set<2>(high, next_up(centre[2] + half_width_m));
  return BoostBox(low, high);
}

// Our squared distances of the values found, sorted as brute force sorts them.
std::vector<Candidate> exact_sorted(const std::vector<Value>& found, const double* query) {
  std::vector<Candidate> rows;
  rows.reserve(found.size());
  for (const auto& [point, index] : found) {
    const double xyz[3] = {bg::get<0>(point), bg::get<1>(point), bg::get<2>(point)};
    rows.emplace_back(sq_dist_m2(xyz, query), index);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

void write_row(const std::vector<Candidate>& rows, std::size_t k, double limit_sq_m2, Neighbours& out) {
  std::size_t written = 0;
  for (const auto& [sq, index] : rows) {
    if (written == k || sq > limit_sq_m2) break;
    out.push(index, sq);
    ++written;
  }
  out.end_query();
}

// Bytes of the nodes as allocated: each node object and its element buffer at its capacity, plus a
// typical allocator header for each of the two allocations.
template <class MembersHolder>
class NodeBytes final : public MembersHolder::visitor_const {
 public:
  using InternalNode = typename MembersHolder::internal_node;
  using Leaf = typename MembersHolder::leaf;

  void operator()(const InternalNode& node) {
    const auto& elements = bgi::detail::rtree::elements(node);
    add(elements);
    for (const auto& child : elements) bgi::detail::rtree::apply_visitor(*this, *child.second);
  }
  void operator()(const Leaf& node) { add(bgi::detail::rtree::elements(node)); }
  std::size_t bytes() const { return bytes_; }

 private:
  static constexpr std::size_t kAllocatorHeaderBytes = 16;

  template <class Elements>
  void add(const Elements& elements) {
    bytes_ += sizeof(typename MembersHolder::node) + elements.capacity() * sizeof(typename Elements::value_type) +
              2 * kAllocatorHeaderBytes;
  }

  std::size_t bytes_ = 0;
};

struct Linear {
  using Parameters = bgi::dynamic_linear;
  static constexpr const char* name = "boost_rtree_linear";
  static constexpr const char* structure = "R-tree (linear split)";
};
struct Quadratic {
  using Parameters = bgi::dynamic_quadratic;
  static constexpr const char* name = "boost_rtree_quadratic";
  static constexpr const char* structure = "R-tree (quadratic split)";
};
struct RStar {
  using Parameters = bgi::dynamic_rstar;
  static constexpr const char* name = "boost_rtree_rstar";
  static constexpr const char* structure = "R*-tree";
};

template <class Variant>
class BoostRTree final : public SearchIndex {
 public:
  using Tree = bgi::rtree<Value, typename Variant::Parameters>;

  explicit BoostRTree(const Params& params) : SearchIndex(describe(params)) {
    max_elements_ = static_cast<std::size_t>(info().bucket->value);
    bulk_ = info().params.at("build") == "bulk";
  }

  std::size_t index_bytes() const override { return index_bytes_; }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = Variant::name;
    info.concurrency = Concurrency::queries;
    info.library = "Boost.Geometry";
    info.version = boost_version();
    info.structure = Variant::structure;
    info.scalar = "double";
    info.knn = Strategy::native;
    info.radius = Strategy::via_box;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_bucket("max_elements", 16, 4, 1024, 4, 128);
    reader.get_choice("build", "bulk", {"bulk", "insert"});
    info.params = reader.finish();
    info.bucket = reader.bucket();
    info.notes =
        "k-NN and ranged ask bgi::nearest for k+1 (its order is arbitrary and it keeps any subset of the "
        "ties at the k-th distance): rows recomputed in double and sorted; where the k-th and next may tie, "
        "every point within the k-th distance is fetched by box and cut to k. Ranged = nearest(p, k+1) && "
        "intersects(box of the ball), pruned by the box, then sq_dist <= d*d. Radius = intersects(box "
        "padded 1e-12 relative + 1 ulp), then sq_dist <= r*r. build=bulk (packing) ignores the split "
        "algorithm: the three variants differ only with build=insert. index_bytes: nodes visited, each "
        "node object plus its element buffer at capacity plus 16 bytes per allocation";
    return info;
  }

  void do_build(const Cloud& model) override {
    tree_.reset();
    std::vector<Value> values;
    values.reserve(static_cast<std::size_t>(model.cols()));
    for (Eigen::Index i = 0; i < model.cols(); ++i) {
      values.emplace_back(to_point(model.col(i).data()), static_cast<PointIndex>(i));
    }
    const typename Variant::Parameters parameters(max_elements_);
    if (bulk_) {
      tree_ = std::make_unique<Tree>(values.begin(), values.end(), parameters);
    } else {
      tree_ = std::make_unique<Tree>(parameters);
      for (const auto& value : values) tree_->insert(value);
    }
    index_bytes_ = count_node_bytes();
  }

  std::size_t count_node_bytes() const {
    using View = bgi::detail::rtree::utilities::view<Tree>;
    const View view(*tree_);
    NodeBytes<typename View::members_holder> counter;
    view.apply_visitor(counter);
    return counter.bytes();
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    search_nearest(queries, k, std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    search_nearest(queries, k, max_dist_m, out);
  }

  void search_nearest(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const {
    out.reset(static_cast<std::size_t>(queries.cols()), static_cast<std::size_t>(k) * queries.cols());
    std::vector<Value> found;
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      write_row(nearest_rows(query, static_cast<std::size_t>(k), max_dist_m, found), static_cast<std::size_t>(k),
                max_dist_m * max_dist_m, out);
    }
  }

  // At least the k nearest within max_dist_m, sorted as brute force sorts them, ties at the k-th complete.
  std::vector<Candidate> nearest_rows(const double* query, std::size_t k, double max_dist_m,
                                      std::vector<Value>& found) const {
    if (k == 0) return {};
    const std::size_t fetch = std::min(k + 1, tree_->size());
    found.clear();
    if (std::isinf(max_dist_m)) {
      tree_->query(bgi::nearest(to_point(query), static_cast<unsigned>(fetch)), std::back_inserter(found));
    } else {
      tree_->query(bgi::nearest(to_point(query), static_cast<unsigned>(fetch)) &&
                       bgi::intersects(ball_box(query, max_dist_m)),
                   std::back_inserter(found));
    }
    std::vector<Candidate> rows = exact_sorted(found, query);
    // At most k: every candidate was found (the model or the box held no more). Otherwise whatever was
    // left out lies at least about as far as the (k+1)-th, which is harmless unless it may tie the k-th.
    if (rows.size() <= k || rows[k].first * (1.0 - kTieMargin) > rows[k - 1].first) return rows;
    return rows_within(query, std::min(rows[k - 1].first, max_dist_m * max_dist_m), found);
  }

  // Every point with squared distance <= limit_sq_m2, sorted as brute force sorts them.
  std::vector<Candidate> rows_within(const double* query, double limit_sq_m2, std::vector<Value>& found) const {
    found.clear();
    tree_->query(bgi::intersects(ball_box(query, std::sqrt(limit_sq_m2))), std::back_inserter(found));
    std::vector<Candidate> rows = exact_sorted(found, query);
    rows.erase(std::find_if(rows.begin(), rows.end(), [&](const Candidate& c) { return c.first > limit_sq_m2; }),
               rows.end());
    return rows;
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    out.reset(static_cast<std::size_t>(queries.cols()));
    const double limit_sq_m2 = radius_m * radius_m;
    std::vector<Value> found;
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      const double* query = queries.col(q).data();
      found.clear();
      tree_->query(bgi::intersects(ball_box(query, radius_m)), std::back_inserter(found));
      for (const auto& [point, index] : found) {
        const double xyz[3] = {bg::get<0>(point), bg::get<1>(point), bg::get<2>(point)};
        const double sq = sq_dist_m2(xyz, query);
        if (sq <= limit_sq_m2) out.push(index, sq);
      }
      out.end_query();
    }
  }

  std::size_t max_elements_ = 16;
  bool bulk_ = true;
  // Not std::optional: the dynamic parameters have no default constructor, and clang evaluates the
  // rtree's default argument when std::optional asks whether it is default-constructible.
  std::unique_ptr<Tree> tree_;
  std::size_t index_bytes_ = 0;
};

}  // namespace

std::unique_ptr<SearchIndex> make_boost_rtree_linear(const Params& params) {
  return std::make_unique<BoostRTree<Linear>>(params);
}

std::unique_ptr<SearchIndex> make_boost_rtree_quadratic(const Params& params) {
  return std::make_unique<BoostRTree<Quadratic>>(params);
}

std::unique_ptr<SearchIndex> make_boost_rtree_rstar(const Params& params) {
  return std::make_unique<BoostRTree<RStar>>(params);
}

}  // namespace nnb::adapters
