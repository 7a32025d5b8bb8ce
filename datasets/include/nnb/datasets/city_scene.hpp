#pragma once
// A synthetic city block for the simulated terrestrial laser scans: a 4 x 4 grid of closed
// blocks (raised sidewalk platforms, perimeter buildings with recessed windows) between 10 m roads on
// gently sloped ground, with street lamps, parked cars and trees. World frame: metres, z up, the centre
// crossing at the origin. Built from std::mt19937_64 with our own mapping (no std distributions), so a
// seed gives the same scene everywhere.
#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace nnb::datasets {

/// A regular grid of rectangular window recesses on one vertical face of a box. u runs along the face
/// from its left end (local y + half_y on the x faces, local x + half_x on the y faces); z from the box bottom.
struct WindowGrid {
  int columns = 0;         ///< 0: no windows on this face
  int rows = 0;
  double u_first_m = 0;    ///< left edge of the first column
  double u_pitch_m = 0;    ///< left edge to left edge
  double width_m = 0;
  double z_first_m = 0;    ///< sill of the first row, above the box bottom
  double z_pitch_m = 0;
  double height_m = 0;
  double depth_m = 0;      ///< how far the recess goes into the box
};

/// A solid box rotated by yaw about the vertical: buildings, sidewalk platforms, car bodies and cabins.
struct SceneBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();      ///< world, metres
  Eigen::Vector3d half_extent_m = Eigen::Vector3d::Ones(); ///< along the local x, y, z axes
  double yaw_rad = 0;                                    ///< world x to local x, about world z
  std::array<WindowGrid, 4> windows{};                   ///< recesses on faces +x, -x, +y, -y
};

/// A vertical capped cylinder: lamp posts, sign posts, tree trunks.
struct ScenePole {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  double radius_m = 0.1;
  double z_bottom_m = 0;
  double z_top_m = 1;
};

/// A tree crown: an axis-aligned ellipsoid that a ray enters to a random foliage depth, or passes through a gap.
struct SceneCrown {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d radii_m = Eigen::Vector3d::Ones();
  double foliage_depth_m = 0.5;  ///< returns lie up to this far (along the ray) inside the crown
  double gap_fraction = 0.2;     ///< share of rays that pass through the crown
};

/// The ground plane z = z0 + slope_x x + slope_y y, for |x|, |y| <= half_size_m (nothing beyond).
struct SceneGround {
  double z0_m = 0;
  double slope_x = 0;
  double slope_y = 0;
  double half_size_m = 100;
};

/// The whole scene. Surface ids number everything a ray can hit: 0 = ground, then boxes, poles, crowns.
struct CityScene {
  SceneGround ground;
  std::vector<SceneBox> boxes;
  std::vector<ScenePole> poles;
  std::vector<SceneCrown> crowns;

  /// Number of surface ids (1 + boxes + poles + crowns).
  std::size_t surface_count() const { return 1 + boxes.size() + poles.size() + crowns.size(); }
};

enum class SurfaceKind { ground, box, pole, crown };

/// The kind of a surface id and its index in that kind's vector (0 for the ground); InputError if out of range.
std::pair<SurfaceKind, std::size_t> surface_of(const CityScene& scene, std::uint32_t surface_id);

/// The city of that seed (same seed, same scene).
CityScene make_city_scene(std::uint64_t seed);

/// Height of the ground plane at (x, y), metres (ignores the extent).
double ground_z_m(const SceneGround& ground, double x, double y);

/// Distance of p (world, metres) from that surface: a 1-Lipschitz signed distance that is 0 exactly on
/// the surface (boxes with their window recesses cut out, capped poles, the ground plane); for crowns 0
/// inside the ellipsoid (foliage) and outside a lower bound on the distance to it. |value| <= how far p is
/// from the surface, so a return with range noise e gives |value| <= |e|.
double surface_distance_m(const CityScene& scene, std::uint32_t surface_id, const Eigen::Vector3d& p);

}  // namespace nnb::datasets
