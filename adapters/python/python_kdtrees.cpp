// The Python k-d trees people use, called through an embedded CPython: SciPy's cKDTree, pykdtree, and
// scikit-learn's KDTree and BallTree. Each query kind is one Python call on the whole query set (numpy views
// over our clouds, no copies); the libraries compute in double, and every distance is recomputed here so
// that all adapters report the same bits. cKDTree's and pykdtree's distance_upper_bound is strict and
// rounding in their cell pruning is not ours, so bounded searches ask slightly wider and cut at <= r.
#include "embedded_python.hpp"
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

// Versions as the build's interpreter reported them, until a build imports the module and reads its own.
#ifndef NNB_SCIPY_VERSION
#define NNB_SCIPY_VERSION "unknown"
#endif
#ifndef NNB_PYKDTREE_VERSION
#define NNB_PYKDTREE_VERSION "unknown"
#endif
#ifndef NNB_SKLEARN_VERSION
#define NNB_SKLEARN_VERSION "unknown"
#endif

namespace nnb::adapters {
namespace {

namespace py = pybind11;
using python::Session;
using python::view_of;

template <class Index>
bool in_model(Index index, std::size_t model_size) {
  if constexpr (std::is_signed_v<Index>) {
    if (index < 0) return false;
  }
  return static_cast<std::size_t>(index) < model_size;
}

/// Appends one row per query from an (n_queries, columns) index array; entries >= model_size are the
/// libraries' "no neighbour here" and are skipped. Distances are left for recompute_sq_dists.
template <class Index>
void append_index_rows(const py::handle& indices, std::size_t n_queries, std::size_t model_size, Neighbours& out) {
  const auto rows = py::array_t<Index, py::array::c_style | py::array::forcecast>::ensure(indices);
  if (!rows) throw py::error_already_set();
  const auto total = static_cast<std::size_t>(rows.size());
  const std::size_t columns = n_queries == 0 ? 0 : total / n_queries;
  const Index* index = rows.data();
  out.reset(n_queries, total);
  for (std::size_t q = 0; q < n_queries; ++q, index += columns) {
    for (std::size_t j = 0; j < columns; ++j) {
      if (in_model(index[j], model_size)) out.push(static_cast<PointIndex>(index[j]), 0.0);
    }
    out.end_query();
  }
}

/// Appends one row per query from a numpy object array whose items are lists of indices (cKDTree's
/// query_ball_point) or integer arrays (scikit-learn's query_radius).
void append_object_rows(const py::handle& result, std::size_t n_queries, Neighbours& out) {
  const auto rows = py::array::ensure(result);
  if (!rows || rows.dtype().kind() != 'O' || static_cast<std::size_t>(rows.size()) != n_queries) {
    throw std::runtime_error("unexpected radius search result");
  }
  PyObject* const* row = static_cast<PyObject* const*>(rows.data());
  out.reset(n_queries);
  for (std::size_t q = 0; q < n_queries; ++q) {
    if (PyList_Check(row[q])) {
      const Py_ssize_t n = PyList_GET_SIZE(row[q]);
      for (Py_ssize_t j = 0; j < n; ++j) {
        out.push(static_cast<PointIndex>(PyLong_AsSsize_t(PyList_GET_ITEM(row[q], j))), 0.0);
      }
    } else {
      const auto items = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(row[q]);
      if (!items) throw py::error_already_set();
      for (py::ssize_t j = 0; j < items.size(); ++j) out.push(static_cast<PointIndex>(items.data()[j]), 0.0);
    }
    out.end_query();
  }
  if (PyErr_Occurred()) throw py::error_already_set();
}

/// What the Python adapters share: the interpreter, the model view, the tree object, the search bound.
class PythonTree : public SearchIndex {
 public:
  PythonTree(AdapterInfo info, const char* module, const char* distribution)
      : SearchIndex(std::move(info)), module_(module), distribution_(distribution) {}

  // Python objects die under the GIL.
  ~PythonTree() override { release(); }

  std::size_t index_bytes() const override { return index_bytes_; }

 protected:
  /// The library's tree over points (an (n, 3) view of the model). Called with the GIL held.
  virtual py::object make_tree(const py::module_& module, const py::object& points) const = 0;
  /// Bytes the tree holds beyond the model points. Called with the GIL held.
  virtual std::size_t measure_tree_bytes() const = 0;

  void do_build(const Cloud& model) final {
    release();
    const Session session;
    const py::module_ module = py::module_::import(module_);
    if (const auto version = python::module_version(module_, distribution_); !version.empty()) {
      mutable_info().version = version;
    }
    model_ = &model;
    model_magnitude_m_ = model.cwiseAbs().maxCoeff();
    model_view_ = view_of(model);
    tree_ = make_tree(module, model_view_);
    index_bytes_ = measure_tree_bytes();
  }

  const Cloud& model() const { return *model_; }
  const py::object& tree() const { return tree_; }

  /// Bound in metres to hand a library so that every point within limit_m in double is found: 1e-12
  /// relative covers the rounding of squaring it, 1e-12 of the coordinates the rounding of cell distances;
  /// one step more for a strict '<', and a floor so that a zero limit still squares above 0.
  double search_bound_m(const Cloud& queries, double limit_m) const {
    const double query_magnitude_m = queries.cols() == 0 ? 0.0 : queries.cwiseAbs().maxCoeff();
    const double scale = std::max({model_magnitude_m_, query_magnitude_m, limit_m});
    const double padded_m = std::max(limit_m * (1.0 + 1e-12) + 1e-12 * scale, 1e-150);
    return next_up(padded_m);
  }

  /// Whether the library shares the model's memory (else its copy counts as index memory).
  bool shares_model(const py::handle& array) const {
    const auto a = py::array::ensure(array);
    return a && a.data() == static_cast<const void*>(model_->data());
  }

 private:
  void release() {
    if (!tree_ && !model_view_) return;
    const Session session;
    tree_ = py::object();
    model_view_ = py::object();
  }

  const char* module_;
  const char* distribution_;
  const Cloud* model_ = nullptr;
  double model_magnitude_m_ = 0.0;
  py::object model_view_;  // the model as numpy sees it; the tree keeps it too
  py::object tree_;
  std::size_t index_bytes_ = 0;
};

/// The libraries whose k-NN query takes a distance bound (scipy, pykdtree): k-NN and ranged search alike.
class BoundedQueryTree : public PythonTree {
 public:
  using PythonTree::PythonTree;

 protected:
  /// The k nearest of each query within bound_m (infinity: none), rows in any order, distances in double.
  virtual void query(const Cloud& queries, int k, double bound_m, Neighbours& out) const = 0;

 private:
  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    query(queries, k, std::numeric_limits<double>::infinity(), out);
    sort_and_truncate(static_cast<std::size_t>(k), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    query(queries, k, search_bound_m(queries, max_dist_m), out);
    filter_by_sq_dist(max_dist_m * max_dist_m, out);
    sort_and_truncate(static_cast<std::size_t>(k), out);
  }
};

AdapterInfo describe(const std::string& name, const std::string& library, const std::string& version,
                     const std::string& structure, const Params& params, const char* bucket_name, int bucket_default,
                     Strategy radius, Strategy ranged, Concurrency concurrency, std::string notes) {
  AdapterInfo info;
  info.name = name;
  info.library = library;
  info.version = version;
  info.structure = structure;
  info.scalar = "double";
  info.knn = Strategy::native;
  info.radius = radius;
  info.ranged = ranged;
  info.concurrency = concurrency;
  ParamReader reader(info.name, params);
  reader.get_bucket(bucket_name, bucket_default, 1, 1 << 20, 1, 64);
  info.params = reader.finish();
  info.bucket = reader.bucket();
  info.notes = std::move(notes);
  return info;
}

// ------------------------------------------------------------------------------------------ SciPy cKDTree

class ScipyCkdTree final : public BoundedQueryTree {
 public:
  explicit ScipyCkdTree(const Params& params)
      : BoundedQueryTree(describe("scipy_ckdtree", "SciPy", NNB_SCIPY_VERSION, "k-d tree", params, "leafsize", 16,
                            Strategy::native, Strategy::native, Concurrency::library,
                            "cKDTree (balanced, compact nodes), workers = the threads asked for (1 by default); distance_upper_bound is strict: ranged "
                            "asks 1e-12 wider (relative and of the coordinates) and cuts at <= r; radius is "
                            "query_ball_point, widened the same way; distances recomputed in double; "
                            "embedded CPython, one call per query set"),
                   "scipy.spatial", "scipy") {}

 private:
  py::object make_tree(const py::module_& spatial, const py::object& points) const override {
    return spatial.attr("cKDTree")(points, py::arg("leafsize") = info().bucket->value);
  }

  // The permutation (one intp a point) and the nodes (ckdtreenode: nine 8-byte fields).
  std::size_t measure_tree_bytes() const override {
    const py::object data = tree().attr("data");
    std::size_t bytes = py::array::ensure(tree().attr("indices")).nbytes() +
                        tree().attr("size").cast<std::size_t>() * 72;
    if (!shares_model(data)) bytes += py::array::ensure(data).nbytes();
    return bytes;
  }

  // One call: query(queries, k[, distance_upper_bound]); misses come back as index n.
  void query(const Cloud& queries, int k, double bound_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) return out.reset();
    {
      const Session session;
      const py::tuple found = tree().attr("query")(view_of(queries), py::arg("k") = k,
                                                   py::arg("distance_upper_bound") = bound_m, py::arg("workers") = threads());
      append_index_rows<std::int64_t>(found[1], n_queries, model_size(), out);
    }
    recompute_sq_dists(model(), queries, out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) return out.reset();
    {
      const Session session;
      const py::object found = tree().attr("query_ball_point")(
          view_of(queries), search_bound_m(queries, radius_m), py::arg("workers") = threads(),
          py::arg("return_sorted") = false);
      append_object_rows(found, n_queries, out);
    }
    recompute_sq_dists(model(), queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }
};

// ------------------------------------------------------------------------------------------ pykdtree

class PyKdTree final : public BoundedQueryTree {
 public:
  explicit PyKdTree(const Params& params)
      : BoundedQueryTree(describe("pykdtree", "pykdtree", NNB_PYKDTREE_VERSION, "k-d tree", params, "leafsize", 16,
                            Strategy::via_knn, Strategy::native, Concurrency::library,
                            "OpenMP limited to the threads asked for (1 by default) around each call; distance_upper_bound is strict: "
                            "ranged asks 1e-12 wider and cuts at <= r; no radius search: k-NN bounded by the "
                            "radius, k grown (at least doubled) for the queries whose rows came back full; distances recomputed "
                            "in double; node memory estimated (not exposed)"),
                   "pykdtree.kdtree", "pykdtree") {}

 private:
  py::object make_tree(const py::module_& kdtree, const py::object& points) const override {
    const python::OmpThreads one_thread(1);
    return kdtree.attr("KDTree")(points, py::arg("leafsize") = info().bucket->value);
  }

  // A uint32 permutation, and nodes (56 bytes: split, bounds, range, children) that Python cannot see:
  // at least one leaf per leafsize points and the inner nodes above them.
  std::size_t measure_tree_bytes() const override {
    const auto n = static_cast<std::size_t>(model().cols());  // model_size() is set once the build returns
    const std::size_t leaves = (n + info().bucket->value - 1) / info().bucket->value;
    std::size_t bytes = n * sizeof(std::uint32_t) + (2 * leaves - 1) * 56;
    const py::object data = tree().attr("data");
    if (!shares_model(data)) bytes += py::array::ensure(data).nbytes();
    return bytes;
  }

  // One call: query(queries, k, distance_upper_bound); misses come back as index n.
  void query(const Cloud& queries, int k, double bound_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) return out.reset();
    {
      const Session session;
      const python::OmpThreads team(threads());
      py::object bound = py::none();
      if (std::isfinite(bound_m)) bound = py::float_(bound_m);
      const py::tuple found =
          tree().attr("query")(view_of(queries), py::arg("k") = k, py::arg("distance_upper_bound") = bound);
      append_index_rows<std::uint32_t>(found[1], n_queries, model_size(), out);
    }
    recompute_sq_dists(model(), queries, out);
  }

  // Bounded k-NN until every row ends before k: then the row holds every point within the bound. The next k
  // extrapolates the fullest row's k-th distance to the radius as on a surface (count ~ r^2, scans), at
  // least doubling: pykdtree's sorted insertion makes a call cost ~k per candidate, so k should not overshoot.
  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    const double bound_m = search_bound_m(queries, radius_m);
    std::vector<Eigen::Index> pending(n_queries);
    for (std::size_t q = 0; q < n_queries; ++q) pending[q] = static_cast<Eigen::Index>(q);
    std::vector<Neighbours> rows(n_queries);  // final row of each query
    Cloud batch;
    Neighbours found;
    std::vector<Eigen::Index> full;
    for (std::size_t k = std::min<std::size_t>(16, model_size()); !pending.empty();) {
      batch.resize(3, static_cast<Eigen::Index>(pending.size()));
      for (std::size_t i = 0; i < pending.size(); ++i) batch.col(static_cast<Eigen::Index>(i)) = queries.col(pending[i]);
      query(batch, static_cast<int>(k), bound_m, found);
      full.clear();
      double next_k = 2.0 * static_cast<double>(k);
      for (std::size_t i = 0; i < pending.size(); ++i) {
        if (found.count(i) == k && k < model_size()) {
          const double kth_sq_m2 = *std::max_element(found.sq_dists.begin() + static_cast<std::ptrdiff_t>(found.offsets[i]),
                                                     found.sq_dists.begin() + static_cast<std::ptrdiff_t>(found.offsets[i + 1]));
          if (kth_sq_m2 > 0.0) next_k = std::max(next_k, 1.2 * static_cast<double>(k) * bound_m * bound_m / kth_sq_m2);
          full.push_back(pending[i]);
          continue;
        }
        Neighbours& row = rows[static_cast<std::size_t>(pending[i])];
        row.reset(1, found.count(i));
        for (std::size_t j = found.offsets[i]; j < found.offsets[i + 1]; ++j) row.push(found.indices[j], found.sq_dists[j]);
        row.end_query();
      }
      pending.swap(full);
      k = static_cast<std::size_t>(std::min(next_k, static_cast<double>(model_size())));
    }
    out.reset(n_queries);
    for (const Neighbours& row : rows) {
      for (std::size_t j = 0; j < row.total(); ++j) out.push(row.indices[j], row.sq_dists[j]);
      out.end_query();
    }
    filter_by_sq_dist(radius_m * radius_m, out);
  }
};

// ------------------------------------------------------------------------------------------ scikit-learn

class SklearnTree final : public PythonTree {
 public:
  SklearnTree(const Params& params, const char* name, const char* cls, const char* structure)
      : PythonTree(describe(name, "scikit-learn", NNB_SKLEARN_VERSION, structure, params, "leaf_size", 40,
                            Strategy::native, Strategy::via_knn, Concurrency::single,
                            std::string(cls) +
                                " (single-threaded); query has no distance bound: ranged is k-NN then a cut at "
                                "<= r; query_radius is inclusive in its own rounding: asked 1e-12 wider and cut "
                                "at <= r; distances recomputed in double"),
                   "sklearn.neighbors", "scikit-learn"),
        class_(cls) {}

 private:
  py::object make_tree(const py::module_& neighbors, const py::object& points) const override {
    return neighbors.attr(class_)(points, py::arg("leaf_size") = info().bucket->value);
  }

  // get_arrays(): the points (ours unless copied), the permutation, the node records and the node bounds.
  std::size_t measure_tree_bytes() const override {
    const py::tuple arrays = tree().attr("get_arrays")();
    std::size_t bytes = 0;
    for (std::size_t i = 0; i < arrays.size(); ++i) {
      if (i == 0 && shares_model(arrays[0])) continue;
      bytes += py::array::ensure(arrays[i]).nbytes();
    }
    return bytes;
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) return out.reset();
    {
      const Session session;
      const py::object found = tree().attr("query")(view_of(queries), py::arg("k") = k,
                                                    py::arg("return_distance") = false);
      append_index_rows<std::int64_t>(found, n_queries, model_size(), out);
    }
    recompute_sq_dists(model(), queries, out);
    sort_and_truncate(static_cast<std::size_t>(k), out);
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    if (n_queries == 0) return out.reset();
    {
      const Session session;
      const py::object found = tree().attr("query_radius")(
          view_of(queries), py::arg("r") = search_bound_m(queries, radius_m), py::arg("return_distance") = false);
      append_object_rows(found, n_queries, out);
    }
    recompute_sq_dists(model(), queries, out);
    filter_by_sq_dist(radius_m * radius_m, out);
  }

  const char* class_;
};

}  // namespace

std::unique_ptr<SearchIndex> make_scipy_ckdtree(const Params& params) {
  return std::make_unique<ScipyCkdTree>(params);
}

std::unique_ptr<SearchIndex> make_pykdtree(const Params& params) { return std::make_unique<PyKdTree>(params); }

std::unique_ptr<SearchIndex> make_sklearn_kdtree(const Params& params) {
  return std::make_unique<SklearnTree>(params, "sklearn_kdtree", "KDTree", "k-d tree");
}

std::unique_ptr<SearchIndex> make_sklearn_balltree(const Params& params) {
  return std::make_unique<SklearnTree>(params, "sklearn_balltree", "BallTree", "ball tree");
}

}  // namespace nnb::adapters
