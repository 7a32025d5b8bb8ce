#pragma once
// Simulated terrestrial laser scans of the synthetic city (city_scene.hpp), standing in for the paper's
// two 16-million-point Riegl VZ-400 scans of Bremen: rays over 360 degrees of azimuth and an elevation
// band, cast analytically against the scene, with range noise, a range window, and misses dropped.
// Points are in the scanner frame (levelled: its z is the world z), in azimuth-column order.
#include "nnb/cloud.hpp"
#include "nnb/datasets/city_scene.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nnb::datasets {

/// The scanner's sampling and range model.
struct ScannerSettings {
  double angular_step_deg = 0.2;      ///< azimuth and elevation step
  double min_elevation_deg = -40.0;
  double max_elevation_deg = 60.0;
  double min_range_m = 1.5;
  double max_range_m = 250.0;
  double range_noise_sigma_m = 0.005; ///< sum of 4 uniforms scaled to this sigma: |noise| <= 2 sqrt(3) sigma
};

/// Largest absolute range noise the settings can produce, metres (2 sqrt(3) sigma).
double max_range_noise_m(const ScannerSettings& settings);
/// Number of rays per scan: azimuth columns x elevation rows.
std::size_t ray_count(const ScannerSettings& settings);

/// Where a levelled scanner stands: its optical centre in the world and its heading.
struct ScannerPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< world, metres
  double yaw_rad = 0;
  /// T_world_scanner: maps scanner-frame points into the world frame (translation in metres).
  Eigen::Matrix4d matrix() const;
};

/// One scan: the returns and what they hit.
struct CityScan {
  Cloud points;                            ///< scanner frame, metres, column by column
  std::vector<std::uint32_t> surface_ids;  ///< per point, the surface its ray hit (filled on request)
  std::size_t n_rays = 0;                  ///< rays cast
  std::size_t n_dropped = 0;               ///< rays without a return inside [min_range, max_range]
};

/// Scans the scene from that pose. The same (scene, pose, settings, seed) gives the same bytes; the
/// noise of each ray depends only on the seed and the ray's index. InputError for a step <= 0 or a
/// field of view or range window that is empty.
CityScan scan_city(const CityScene& scene, const ScannerPose& pose, const ScannerSettings& settings,
                   std::uint64_t seed, bool with_surface_ids = false);

/// A named simulated pair: scan A (model) and scan B (query) of the same city, a few metres apart.
struct CityPairPreset {
  std::string name;         ///< e.g. city-tls-16m
  double angular_step_deg;  ///< sets the point count (about 16M per scan at the finest)
};

/// The simulated pairs, smallest first: city-tls-15k, -60k, -250k, -1m, -4m, -16m (steps halve: x4 points).
const std::vector<CityPairPreset>& city_pair_presets();
/// The preset of that name, or nothing.
std::optional<CityPairPreset> find_city_pair_preset(const std::string& name);

/// The fixed scanner poses of every simulated pair and the poses between them.
struct CityPairPoses {
  ScannerPose scanner_a;
  ScannerPose scanner_b;
  Eigen::Matrix4d reference;  ///< T_A_B: maps scan B's points into scan A's frame (the ground truth)
  Eigen::Matrix4d initial;    ///< reference perturbed by 0.3 m and 2 degrees (a fixed, deterministic guess)
};

/// The poses of the simulated pairs (the same for every seed and size).
const CityPairPoses& city_pair_poses();
/// The scanner settings of a preset: its step, everything else the defaults.
ScannerSettings city_pair_settings(const CityPairPreset& preset);
/// Scan A (scan_b false) or B of a preset with that seed, in its own scanner frame.
CityScan scan_city_pair(const CityPairPreset& preset, bool scan_b, std::uint64_t seed, bool with_surface_ids = false);

}  // namespace nnb::datasets
