// The named simulated pairs (city-tls-*): two scans of the same city from levelled scanners 4.9 m
// apart with 12 degrees more yaw, at angular steps chosen for about 15k .. 16M points per scan.
#include "nnb/datasets/city_scan.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace nnb::datasets {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

ScannerPose standing_at(const SceneGround& ground, double x, double y, double yaw_deg) {
  // 1.7 m above the road: tripod plus the optical centre of a VZ-400.
  return {Eigen::Vector3d(x, y, ground_z_m(ground, x, y) + 1.7), yaw_deg * kDeg};
}

CityPairPoses make_poses() {
  const SceneGround ground = make_city_scene(1).ground;  // the slopes are fixed, the same for every seed
  CityPairPoses poses;
  poses.scanner_a = standing_at(ground, -2.0, 1.5, 25.0);
  poses.scanner_b = standing_at(ground, 2.2, -1.0, 37.0);
  poses.reference = poses.scanner_a.matrix().inverse() * poses.scanner_b.matrix();
  // Initial guess: the reference moved by 0.3 m and turned by 2 degrees about fixed oblique axes (in B's frame).
  Eigen::Matrix4d perturbation = Eigen::Matrix4d::Identity();
  perturbation.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(2.0 * kDeg, Eigen::Vector3d(0.2, -0.3, 1.0).normalized()).toRotationMatrix();
  perturbation.topRightCorner<3, 1>() = 0.3 * Eigen::Vector3d(1.0, -1.0, 0.5).normalized();
  poses.initial = poses.reference * perturbation;
  return poses;
}

}  // namespace

const std::vector<CityPairPreset>& city_pair_presets() {
  // Steps halve from one size to the next (4x the rays). Points of scan A / B with seed 1: 15,712 / 15,725;
  // 62,731 / 62,721; 250,625 / 250,581; 1,001,326 / 1,001,240; 4,003,357 / 4,003,114; 16,010,273 / 16,009,593.
  static const std::vector<CityPairPreset> presets{
      {"city-tls-15k", 1.264}, {"city-tls-60k", 0.632}, {"city-tls-250k", 0.316},
      {"city-tls-1m", 0.158},  {"city-tls-4m", 0.079},  {"city-tls-16m", 0.0395}};
  return presets;
}

std::optional<CityPairPreset> find_city_pair_preset(const std::string& name) {
  for (const auto& preset : city_pair_presets()) {
    if (preset.name == name) return preset;
  }
  return std::nullopt;
}

const CityPairPoses& city_pair_poses() {
  static const CityPairPoses poses = make_poses();
  return poses;
}

ScannerSettings city_pair_settings(const CityPairPreset& preset) {
  ScannerSettings settings;
  settings.angular_step_deg = preset.angular_step_deg;
  return settings;
}

CityScan scan_city_pair(const CityPairPreset& preset, bool scan_b, std::uint64_t seed, bool with_surface_ids) {
  const CityScene scene = make_city_scene(seed);
  const CityPairPoses& poses = city_pair_poses();
  // Different noise per scan: the seed of scan B is derived from, not equal to, the scene's seed.
  const std::uint64_t noise_seed = scan_b ? seed ^ 0xB0B0B0B0B0B0B0B0ULL : seed;
  return scan_city(scene, scan_b ? poses.scanner_b : poses.scanner_a, city_pair_settings(preset), noise_seed,
                   with_surface_ids);
}

}  // namespace nnb::datasets
