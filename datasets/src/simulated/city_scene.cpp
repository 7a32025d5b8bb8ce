// The synthetic city: layout from std::mt19937_64 words mapped by hand (uniform() below), and the
// signed distances the tests use to check that every simulated return lies on the surface it hit.
#include "nnb/datasets/city_scene.hpp"

#include "nnb/cloud.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace nnb::datasets {
namespace {

constexpr int kBlocksPerSide = 4;
constexpr double kBlockPitch_m = 58.0;     // road centre to road centre
constexpr double kRoadWidth_m = 10.0;
constexpr double kPlatformHalf_m = 24.0;   // block incl. its 4 m sidewalk ring
constexpr double kBuildingHalf_m = 20.0;   // building area of a block
constexpr double kBuildingDepth_m = 12.0;  // perimeter buildings around a courtyard
constexpr double kCurb_m = 0.15;
constexpr double kBuried_m = 2.0;          // boxes reach this far below the surface they stand on

// Uniform on [lo, hi) from the top 53 bits of one word (exact scaling, one rounding in the affine map).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  constexpr double kTwoToMinus53 = 1.0 / 9007199254740992.0;
  return lo + (hi - lo) * (static_cast<double>(rng() >> 11) * kTwoToMinus53);
}

bool chance(std::mt19937_64& rng, double p) { return uniform(rng, 0.0, 1.0) < p; }

// Windows centred on a face of length face_m and box height height_m (box bottom kBuried_m below the street).
WindowGrid window_grid(std::mt19937_64& rng, double face_m, double height_m) {
  WindowGrid g;
  g.width_m = uniform(rng, 1.0, 1.4);
  g.u_pitch_m = uniform(rng, 2.4, 3.2);
  g.height_m = uniform(rng, 1.5, 1.9);
  g.z_pitch_m = uniform(rng, 3.0, 3.5);
  g.depth_m = uniform(rng, 0.15, 0.35);
  g.z_first_m = kBuried_m + uniform(rng, 0.9, 1.3);
  const double margin_m = 0.8;  // keeps recesses (and their walls) clear of the box edges
  const double usable_m = face_m - 2 * margin_m;
  if (usable_m < g.width_m) return WindowGrid{};
  g.columns = 1 + static_cast<int>(std::floor((usable_m - g.width_m) / g.u_pitch_m));
  g.u_first_m = 0.5 * (face_m - (g.columns - 1) * g.u_pitch_m - g.width_m);
  const double top_clear_m = height_m + kBuried_m - 0.6;
  if (top_clear_m < g.z_first_m + g.height_m) return WindowGrid{};
  g.rows = 1 + static_cast<int>(std::floor((top_clear_m - g.z_first_m - g.height_m) / g.z_pitch_m));
  return g;
}

void add_building(CityScene& scene, std::mt19937_64& rng, double x0, double x1, double y0, double y1,
                  double base_z) {
  const double height_m = uniform(rng, 9.0, 24.0);
  SceneBox b;
  b.centre = {0.5 * (x0 + x1), 0.5 * (y0 + y1), base_z - kBuried_m + 0.5 * (height_m + kBuried_m)};
  b.half_extent_m = {0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.5 * (height_m + kBuried_m)};
  b.windows[0] = window_grid(rng, y1 - y0, height_m);
  b.windows[1] = window_grid(rng, y1 - y0, height_m);
  b.windows[2] = window_grid(rng, x1 - x0, height_m);
  b.windows[3] = window_grid(rng, x1 - x0, height_m);
  scene.boxes.push_back(b);
}

// Splits [lo, hi] into pieces 8..15 m wide (the last takes the rest).
std::vector<double> split(std::mt19937_64& rng, double lo, double hi) {
  std::vector<double> cuts{lo};
  while (hi - cuts.back() > 23.0) cuts.push_back(cuts.back() + uniform(rng, 8.0, 15.0));
  cuts.push_back(hi);
  return cuts;
}

// A perimeter block: north and south rows span the full width, west and east rows fill between them.
void add_buildings(CityScene& scene, std::mt19937_64& rng, double cx, double cy, double base_z) {
  const double x0 = cx - kBuildingHalf_m, x1 = cx + kBuildingHalf_m;
  const double y0 = cy - kBuildingHalf_m, y1 = cy + kBuildingHalf_m;
  for (const bool north : {false, true}) {
    const double ya = north ? y1 - kBuildingDepth_m : y0, yb = north ? y1 : y0 + kBuildingDepth_m;
    const auto cuts = split(rng, x0, x1);
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) add_building(scene, rng, cuts[i], cuts[i + 1], ya, yb, base_z);
  }
  for (const bool east : {false, true}) {
    const double xa = east ? x1 - kBuildingDepth_m : x0, xb = east ? x1 : x0 + kBuildingDepth_m;
    const auto cuts = split(rng, y0 + kBuildingDepth_m, y1 - kBuildingDepth_m);
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) add_building(scene, rng, xa, xb, cuts[i], cuts[i + 1], base_z);
  }
}

// A car parked along a block side: body above the wheels (rays pass underneath) and a cabin.
void add_car(CityScene& scene, std::mt19937_64& rng, double x, double y, double yaw, double ground_z) {
  const double half_length = uniform(rng, 2.1, 2.45), half_width = uniform(rng, 0.87, 0.95);
  const double body_top = ground_z + uniform(rng, 0.95, 1.1);
  SceneBox body;
  body.centre = {x, y, 0.5 * (ground_z + 0.3 + body_top)};
  body.half_extent_m = {half_length, half_width, 0.5 * (body_top - ground_z - 0.3)};
  body.yaw_rad = yaw;
  SceneBox cabin = body;
  const double cabin_top = body_top + uniform(rng, 0.4, 0.55);
  cabin.centre.z() = 0.5 * (body_top + cabin_top);
  cabin.half_extent_m = {half_length * uniform(rng, 0.5, 0.6), half_width * 0.9, 0.5 * (cabin_top - body_top)};
  scene.boxes.push_back(body);
  scene.boxes.push_back(cabin);
}

void add_tree(CityScene& scene, std::mt19937_64& rng, double x, double y, double base_z) {
  SceneCrown crown;
  crown.radii_m = {uniform(rng, 1.6, 2.2), 0, uniform(rng, 2.0, 3.2)};
  crown.radii_m.y() = crown.radii_m.x() * uniform(rng, 0.85, 1.0);
  crown.centre = {x, y, base_z + uniform(rng, 2.2, 3.0) + crown.radii_m.z()};
  crown.foliage_depth_m = uniform(rng, 0.3, 0.7);
  crown.gap_fraction = uniform(rng, 0.1, 0.3);
  scene.crowns.push_back(crown);
  scene.poles.push_back({Eigen::Vector2d(x, y), uniform(rng, 0.12, 0.2), base_z - kBuried_m, crown.centre.z()});
}

// Street furniture along the four sides of a block: lamps and trees on the sidewalk, cars on the road.
void add_street(CityScene& scene, std::mt19937_64& rng, double cx, double cy, double platform_z) {
  const SceneGround& g = scene.ground;
  for (int side = 0; side < 4; ++side) {
    const bool along_x = side < 2;  // sides 0, 1: south and north (run along x)
    const double sign = side % 2 == 0 ? -1.0 : 1.0;
    const bool trees = chance(rng, 0.5);
    const double lamp_offset = uniform(rng, 0.0, 6.0);
    for (double s = -kPlatformHalf_m + 2.0; s < kPlatformHalf_m - 2.0; s += 3.0) {
      const double curb = sign * (kPlatformHalf_m - 1.0);  // 1 m in from the curb
      const double px = along_x ? cx + s : cx + curb, py = along_x ? cy + curb : cy + s;
      const double slot = std::fmod(s + kPlatformHalf_m + lamp_offset, 18.0);
      if (slot < 3.0) {
        scene.poles.push_back({Eigen::Vector2d(px, py), 0.07, platform_z - kBuried_m,
                               platform_z + uniform(rng, 6.0, 7.0)});
      } else if (trees && (slot >= 7.5 && slot < 10.5)) {
        const double in = sign * 0.6;  // trees a little further from the curb
        add_tree(scene, rng, along_x ? px : px - in, along_x ? py - in : py, platform_z);
      }
    }
    // Cars: 6 m slots along the block, each taken with probability 0.6, 1.1 m off the curb.
    for (double s = -kPlatformHalf_m + 3.0; s <= kPlatformHalf_m - 3.0; s += 6.0) {
      if (!chance(rng, 0.6)) continue;
      const double off = sign * (kPlatformHalf_m + 1.1 + 0.9);
      const double jitter = uniform(rng, -0.6, 0.6);
      const double x = along_x ? cx + s + jitter : cx + off, y = along_x ? cy + off : cy + s + jitter;
      const double yaw = (along_x ? 0.0 : 1.5707963267948966) + uniform(rng, -0.03, 0.03);
      add_car(scene, rng, x, y, yaw, ground_z_m(g, x, y));
    }
  }
}

double length2(double a, double b) { return std::sqrt(a * a + b * b); }
double length3(double a, double b, double c) { return std::sqrt(a * a + b * b + c * c); }

// Exact signed distance of q from an axis-aligned box centred at c with half extents h.
double box_sdf(const Eigen::Vector3d& q, const Eigen::Vector3d& c, const Eigen::Vector3d& h) {
  const Eigen::Vector3d d = (q - c).cwiseAbs() - h;
  const double outside = length3(std::max(d.x(), 0.0), std::max(d.y(), 0.0), std::max(d.z(), 0.0));
  return outside + std::min(d.maxCoeff(), 0.0);
}

// Signed distance of the box minus its window recesses. Each recess is a box reaching 0.5 m out of the
// face, so the openings count as air; max(box, -recesses) is 1-Lipschitz and 0 exactly on the surface.
double building_sdf(const SceneBox& b, const Eigen::Vector3d& world) {
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const Eigen::Vector3d r = world - b.centre;
  const Eigen::Vector3d q(c * r.x() + s * r.y(), -s * r.x() + c * r.y(), r.z());
  const Eigen::Vector3d& h = b.half_extent_m;
  const double solid = box_sdf(q, Eigen::Vector3d::Zero(), h);
  double recess = 1e300;
  for (int face = 0; face < 4; ++face) {
    const WindowGrid& g = b.windows[face];
    const int normal_axis = face < 2 ? 0 : 1, u_axis = 1 - normal_axis;
    const double sign = face % 2 == 0 ? 1.0 : -1.0;
    for (int col = 0; col < g.columns; ++col) {
      for (int row = 0; row < g.rows; ++row) {
        Eigen::Vector3d centre, half;
        const double inner = h[normal_axis] - g.depth_m, outer = h[normal_axis] + 0.5;
        centre[normal_axis] = sign * 0.5 * (inner + outer);
        half[normal_axis] = 0.5 * (outer - inner);
        centre[u_axis] = -h[u_axis] + g.u_first_m + col * g.u_pitch_m + 0.5 * g.width_m;
        half[u_axis] = 0.5 * g.width_m;
        centre[2] = -h[2] + g.z_first_m + row * g.z_pitch_m + 0.5 * g.height_m;
        half[2] = 0.5 * g.height_m;
        recess = std::min(recess, box_sdf(q, centre, half));
      }
    }
  }
  return std::max(solid, -recess);
}

double pole_sdf(const ScenePole& p, const Eigen::Vector3d& q) {
  const double dr = length2(q.x() - p.centre_xy.x(), q.y() - p.centre_xy.y()) - p.radius_m;
  const double dz = std::max(p.z_bottom_m - q.z(), q.z() - p.z_top_m);
  return std::min(std::max(dr, dz), 0.0) + length2(std::max(dr, 0.0), std::max(dz, 0.0));
}

// 0 inside; outside (|(q - c) / radii| - 1) * min radius, a lower bound on the distance.
double crown_distance(const SceneCrown& crown, const Eigen::Vector3d& q) {
  const double scaled = ((q - crown.centre).cwiseQuotient(crown.radii_m)).norm();
  return std::max(scaled - 1.0, 0.0) * crown.radii_m.minCoeff();
}

}  // namespace

double ground_z_m(const SceneGround& ground, double x, double y) {
  return ground.z0_m + ground.slope_x * x + ground.slope_y * y;
}

std::pair<SurfaceKind, std::size_t> surface_of(const CityScene& scene, std::uint32_t surface_id) {
  std::size_t i = surface_id;
  if (i == 0) return {SurfaceKind::ground, 0};
  i -= 1;
  if (i < scene.boxes.size()) return {SurfaceKind::box, i};
  i -= scene.boxes.size();
  if (i < scene.poles.size()) return {SurfaceKind::pole, i};
  i -= scene.poles.size();
  if (i < scene.crowns.size()) return {SurfaceKind::crown, i};
  throw InputError("surface id " + std::to_string(surface_id) + " out of range (the scene has " +
                   std::to_string(scene.surface_count()) + ")");
}

CityScene make_city_scene(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  CityScene scene;
  // Fixed slopes (0.2 % and -0.1 %): the scanner heights, hence the pair's poses, do not depend on the seed.
  scene.ground = {0.0, 0.002, -0.001, kBlocksPerSide / 2 * kBlockPitch_m + 0.5 * kRoadWidth_m};
  std::vector<std::array<double, 3>> blocks;
  for (int i = 0; i < kBlocksPerSide; ++i) {
    for (int j = 0; j < kBlocksPerSide; ++j) {
      const double cx = (i - kBlocksPerSide / 2 + 0.5) * kBlockPitch_m, cy = (j - kBlocksPerSide / 2 + 0.5) * kBlockPitch_m;
      blocks.push_back({cx, cy, ground_z_m(scene.ground, cx, cy) + kCurb_m});
    }
  }
  for (const auto& [cx, cy, top] : blocks) {
    SceneBox platform;
    platform.centre = {cx, cy, top - 0.5 * kBuried_m};
    platform.half_extent_m = {kPlatformHalf_m, kPlatformHalf_m, 0.5 * kBuried_m};
    scene.boxes.push_back(platform);
    add_buildings(scene, rng, cx, cy, top);
  }
  for (const auto& [cx, cy, top] : blocks) add_street(scene, rng, cx, cy, top);
  return scene;
}

double surface_distance_m(const CityScene& scene, std::uint32_t surface_id, const Eigen::Vector3d& p) {
  const auto [kind, i] = surface_of(scene, surface_id);
  switch (kind) {
    case SurfaceKind::ground: {
      const SceneGround& g = scene.ground;
      return (p.z() - ground_z_m(g, p.x(), p.y())) / length3(g.slope_x, g.slope_y, 1.0);
    }
    case SurfaceKind::box: return building_sdf(scene.boxes[i], p);
    case SurfaceKind::pole: return pole_sdf(scene.poles[i], p);
    case SurfaceKind::crown: return crown_distance(scene.crowns[i], p);
  }
  return 0.0;
}

}  // namespace nnb::datasets
