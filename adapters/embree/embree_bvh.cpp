// Intel Embree 3's BVH, searched with point queries. Embree has no neighbour search of its own: rtcPointQuery
// walks the BVH and calls back for every primitive whose box meets the query sphere, and the callback may
// shrink the sphere. Each model point is one primitive of a user geometry; the callback measures the exact
// distance in double, keeps the k best and shrinks the sphere to the k-th distance (a pruned k-NN and ranged
// search), or keeps every point within the radius.
//
// Embree is float only: boxes and the query are float coordinates relative to the model's bounding-box
// centre (FloatFrame), boxes rounded outward, and every sphere handed to Embree is the exact limit widened for
// float rounding (of the query point, the coordinates and Embree's box test) and rounded up to float.
// RTC_GEOMETRY_TYPE_SPHERE_POINT cannot be used: point queries do not support point geometries.
#include <embree3/rtcore.h>

#include "../float_libs/float_frame.hpp"
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace nnb::adapters {
namespace {

using Candidate = std::pair<double, PointIndex>;  // (squared distance, index): brute force's order

struct DeviceRelease {
  void operator()(RTCDevice device) const { rtcReleaseDevice(device); }
};
struct SceneRelease {
  void operator()(RTCScene scene) const { rtcReleaseScene(scene); }
};
using DeviceHandle = std::unique_ptr<std::remove_pointer_t<RTCDevice>, DeviceRelease>;
using SceneHandle = std::unique_ptr<std::remove_pointer_t<RTCScene>, SceneRelease>;

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// The smallest float >= x (infinity beyond float's range).
float float_at_least(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) < x ? next_up(f) : f;
}

// Single-threaded by request: Embree's tasking system (TBB) would otherwise build on every core.
DeviceHandle new_device() {
  DeviceHandle device(rtcNewDevice("threads=1"));
  if (!device) throw std::runtime_error("embree_bvh: rtcNewDevice failed (error " +
                                        std::to_string(rtcGetDeviceError(nullptr)) + ")");
  return device;
}

std::string embree_version(RTCDevice device) {
  return std::to_string(rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MAJOR)) + "." +
         std::to_string(rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MINOR)) + "." +
         std::to_string(rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_PATCH));
}

RTCBuildQuality parse_quality(const std::string& word) {
  if (word == "low") return RTC_BUILD_QUALITY_LOW;
  if (word == "high") return RTC_BUILD_QUALITY_HIGH;
  return RTC_BUILD_QUALITY_MEDIUM;
}

// What the bounds callback reads while the scene is committed.
struct ModelInFrame {
  const Cloud* model = nullptr;
  const FloatFrame* frame = nullptr;
};

// The float box of one point: its frame coordinates one float step outward on each side, so that it holds
// the exact (double) coordinates.
void point_bounds(const RTCBoundsFunctionArguments* args) {
  const auto& input = *static_cast<const ModelInFrame*>(args->geometryUserPtr);
  const double* point = input.model->col(static_cast<Eigen::Index>(args->primID)).data();
  float lower[3];
  float upper[3];
  for (int d = 0; d < 3; ++d) {
    const float c = input.frame->coord(point, d);
    lower[d] = next_down(c);
    upper[d] = next_up(c);
  }
  RTCBounds& box = *args->bounds_o;
  box.lower_x = lower[0];
  box.lower_y = lower[1];
  box.lower_z = lower[2];
  box.upper_x = upper[0];
  box.upper_y = upper[1];
  box.upper_z = upper[2];
}

// One k-NN or ranged query in flight: the k best so far as a max-heap on (sq_dist, index).
struct NearestQuery {
  const Cloud* model;
  const FloatFrame* frame;
  const double* query;
  std::size_t k;
  double limit_sq_m2;
  std::vector<Candidate>* heap;
};

// Keeps the point if it is among the k best; once k are held, shrinks the sphere to the k-th distance
// widened for float rounding, so that no point as near as the k-th is culled (ties included).
bool keep_nearest(RTCPointQueryFunctionArguments* args) {
  const auto& state = *static_cast<const NearestQuery*>(args->userPtr);
  const double sq_m2 = sq_dist_m2(state.query, state.model->col(static_cast<Eigen::Index>(args->primID)).data());
  if (sq_m2 > state.limit_sq_m2) return false;
  const Candidate candidate{sq_m2, static_cast<PointIndex>(args->primID)};
  std::vector<Candidate>& heap = *state.heap;
  if (heap.size() < state.k) {
    heap.push_back(candidate);
    std::push_heap(heap.begin(), heap.end());
  } else if (candidate < heap.front()) {
    std::pop_heap(heap.begin(), heap.end());
    heap.back() = candidate;
    std::push_heap(heap.begin(), heap.end());
  } else {
    return false;
  }
  if (heap.size() < state.k) return false;
  const float radius = float_at_least(state.frame->search_radius_m(state.query, std::sqrt(heap.front().first)));
  if (!(radius < args->query->radius)) return false;
  args->query->radius = radius;
  return true;  // tells Embree the sphere shrank
}

// One radius query in flight: every point within the limit goes straight into the result.
struct RadiusQuery {
  const Cloud* model;
  const double* query;
  double limit_sq_m2;
  Neighbours* out;
};

bool keep_within(RTCPointQueryFunctionArguments* args) {
  const auto& state = *static_cast<const RadiusQuery*>(args->userPtr);
  const double sq_m2 = sq_dist_m2(state.query, state.model->col(static_cast<Eigen::Index>(args->primID)).data());
  if (sq_m2 <= state.limit_sq_m2) state.out->push(static_cast<PointIndex>(args->primID), sq_m2);
  return false;
}

class EmbreeBvh final : public SearchIndex {
 public:
  explicit EmbreeBvh(const Params& params) : SearchIndex(describe(params)), device_(new_device()) {
    mutable_info().version = embree_version(device_.get());
    quality_ = parse_quality(info().params.at("build_quality"));
    rtcSetDeviceMemoryMonitorFunction(device_.get(), &count_bytes, &device_bytes_);
  }

  ~EmbreeBvh() override {
    scene_.reset();  // before the device it belongs to
    device_.reset();
  }

  // What Embree's own memory monitor reports for this device: the BVH, the primitive references and the
  // scene's bookkeeping (the adapter itself holds no copy of the points).
  std::size_t index_bytes() const override {
    const long long bytes = device_bytes_.load();
    return bytes > 0 ? static_cast<std::size_t>(bytes) : 0;
  }

 private:
  static AdapterInfo describe(const Params& params) {
    AdapterInfo info;
    info.name = "embree_bvh";
    info.concurrency = Concurrency::queries;
    info.library = "Embree";
    info.version = RTC_VERSION_STRING;  // replaced by the run-time library's version in the constructor
    info.structure = "BVH";
    info.scalar = "float";
    info.knn = Strategy::native;
    info.radius = Strategy::native;
    info.ranged = Strategy::native;
    ParamReader reader(info.name, params);
    reader.get_choice("build_quality", "medium", {"low", "medium", "high"});
    info.params = reader.finish();
    info.notes =
        "no neighbour search in Embree: rtcPointQuery over a user geometry (one primitive a point, float boxes "
        "rounded outward, coordinates relative to the model's box centre) calls back per primitive whose box "
        "meets the query sphere; the callback computes distances in double, keeps the k best and shrinks the "
        "sphere to the k-th distance (k-NN, ranged) or keeps all within r (radius); every sphere is the exact "
        "limit widened by 1e-5 relative + 1e-6 of the coordinates and rounded up to float, then cut at <= r; "
        "device threads=1 (single-threaded build); index_bytes from Embree's memory monitor";
    return info;
  }

  static bool count_bytes(void* counter, ssize_t bytes, bool /*post*/) {
    static_cast<std::atomic<long long>*>(counter)->fetch_add(static_cast<long long>(bytes));
    return true;
  }

  void do_build(const Cloud& model) override {
    scene_.reset();
    frame_.fit(model);
    model_ = &model;
    input_ = ModelInFrame{&model, &frame_};
    SceneHandle scene(rtcNewScene(device_.get()));
    rtcSetSceneBuildQuality(scene.get(), quality_);
    RTCGeometry points = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(points, static_cast<unsigned int>(model.cols()));
    rtcSetGeometryUserData(points, &input_);
    rtcSetGeometryBoundsFunction(points, &point_bounds, nullptr);
    rtcCommitGeometry(points);
    rtcAttachGeometry(scene.get(), points);
    rtcReleaseGeometry(points);  // the scene holds it
    rtcCommitScene(scene.get());
    if (const RTCError error = rtcGetDeviceError(device_.get()); error != RTC_ERROR_NONE) {
      throw std::runtime_error("embree_bvh: building the scene failed (Embree error " + std::to_string(error) + ")");
    }
    scene_ = std::move(scene);
  }

  RTCPointQuery point_query(const double* query, float radius) const {
    RTCPointQuery q;
    q.x = frame_.coord(query, 0);
    q.y = frame_.coord(query, 1);
    q.z = frame_.coord(query, 2);
    q.time = 0.0f;
    q.radius = radius;
    return q;
  }

  void do_knn(const Cloud& queries, int k, Neighbours& out) const override {
    search_nearest(queries, static_cast<std::size_t>(k), std::numeric_limits<double>::infinity(), out);
  }

  void do_ranged(const Cloud& queries, int k, double max_dist_m, Neighbours& out) const override {
    search_nearest(queries, static_cast<std::size_t>(k), max_dist_m, out);
  }

  void search_nearest(const Cloud& queries, std::size_t k, double max_dist_m, Neighbours& out) const {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries, n_queries * k);
    std::vector<Candidate> heap;
    heap.reserve(k);
    NearestQuery state{model_, &frame_, nullptr, k, max_dist_m * max_dist_m, &heap};
    RTCPointQueryContext context;
    for (std::size_t q = 0; q < n_queries; ++q) {
      state.query = queries.col(static_cast<Eigen::Index>(q)).data();
      heap.clear();
      const float start_radius =
          std::isinf(max_dist_m) ? kInfinity : float_at_least(frame_.search_radius_m(state.query, max_dist_m));
      RTCPointQuery query = point_query(state.query, start_radius);
      rtcInitPointQueryContext(&context);
      rtcPointQuery(scene_.get(), &query, &context, &keep_nearest, &state);
      std::sort_heap(heap.begin(), heap.end());
      for (const auto& [sq_m2, index] : heap) out.push(index, sq_m2);
      out.end_query();
    }
  }

  void do_radius(const Cloud& queries, double radius_m, Neighbours& out) const override {
    const auto n_queries = static_cast<std::size_t>(queries.cols());
    out.reset(n_queries);
    RadiusQuery state{model_, nullptr, radius_m * radius_m, &out};
    RTCPointQueryContext context;
    for (std::size_t q = 0; q < n_queries; ++q) {
      state.query = queries.col(static_cast<Eigen::Index>(q)).data();
      RTCPointQuery query = point_query(state.query, float_at_least(frame_.search_radius_m(state.query, radius_m)));
      rtcInitPointQueryContext(&context);
      rtcPointQuery(scene_.get(), &query, &context, &keep_within, &state);
      out.end_query();
    }
  }

  DeviceHandle device_;
  SceneHandle scene_;
  RTCBuildQuality quality_ = RTC_BUILD_QUALITY_MEDIUM;
  std::atomic<long long> device_bytes_{0};
  FloatFrame frame_;
  ModelInFrame input_;
  const Cloud* model_ = nullptr;
};

}  // namespace

std::unique_ptr<SearchIndex> make_embree_bvh(const Params& params) { return std::make_unique<EmbreeBvh>(params); }

}  // namespace nnb::adapters
