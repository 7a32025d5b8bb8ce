// The simulated city scans: every return on the surface its ray hit, determinism, the pair's
// known pose, dropped misses and range limits, counts versus angular step, and the catalog entries.
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/city_scan.hpp"
#include "nnb/registry.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <iostream>

namespace ds = nnb::datasets;
using ds::SurfaceKind;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

ds::ScannerSettings coarse(double step_deg = 0.7) {
  ds::ScannerSettings s;
  s.angular_step_deg = step_deg;
  return s;
}

Eigen::Vector3d to_world(const Eigen::Matrix4d& T, const Eigen::Vector3d& p) {
  return T.topLeftCorner<3, 3>() * p + T.topRightCorner<3, 1>();
}

bool same_bytes(const nnb::Cloud& a, const nnb::Cloud& b) {
  return a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

struct Deviation {
  std::array<double, 4> max_abs_m{};       // per SurfaceKind
  std::array<std::size_t, 4> points{};
};

// Largest |surface distance| of each kind, every stride-th point put into the world by T_world_scanner.
Deviation deviations(const ds::CityScene& scene, const ds::CityScan& scan, const Eigen::Matrix4d& T_world_scanner,
                     Eigen::Index stride = 1) {
  Deviation d;
  for (Eigen::Index i = 0; i < scan.points.cols(); i += stride) {
    const auto id = scan.surface_ids[static_cast<std::size_t>(i)];
    const auto kind = static_cast<std::size_t>(ds::surface_of(scene, id).first);
    const double dist = std::abs(ds::surface_distance_m(scene, id, to_world(T_world_scanner, scan.points.col(i))));
    d.max_abs_m[kind] = std::max(d.max_abs_m[kind], dist);
    ++d.points[kind];
  }
  return d;
}

void print(const char* what, const Deviation& d) {
  const char* names[] = {"ground", "box", "pole", "crown"};
  std::cout << what << ":";
  for (int k = 0; k < 4; ++k) std::cout << " " << names[k] << " " << d.points[k] << " pts max " << d.max_abs_m[k] << " m;";
  std::cout << "\n";
}

}  // namespace

TEST(CityScan, NoiselessReturnsLieExactlyOnTheSurfaceTheyHit) {
  const auto scene = ds::make_city_scene(1);
  auto settings = coarse();
  settings.range_noise_sigma_m = 0.0;
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_a;
  const auto scan = ds::scan_city(scene, pose, settings, 1, true);
  ASSERT_EQ(scan.surface_ids.size(), static_cast<std::size_t>(scan.points.cols()));
  const Deviation d = deviations(scene, scan, pose.matrix());
  print("noiseless", d);
  for (int k = 0; k < 4; ++k) EXPECT_GT(d.points[k], 100u) << "kind " << k << " hardly hit";
  for (int k = 0; k < 3; ++k) EXPECT_LE(d.max_abs_m[k], 1e-9) << "kind " << k;
  EXPECT_LE(d.max_abs_m[3], 1e-9) << "crown returns must lie inside their crown";
}

TEST(CityScan, NoisyReturnsLieWithinTheNoiseBound) {
  const auto scene = ds::make_city_scene(1);
  const auto settings = coarse();
  const double bound_m = ds::max_range_noise_m(settings);
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_a;
  const auto scan = ds::scan_city(scene, pose, settings, 1, true);
  const Deviation d = deviations(scene, scan, pose.matrix());
  print("noisy", d);
  std::cout << "noise bound " << bound_m << " m\n";
  for (int k = 0; k < 4; ++k) EXPECT_LE(d.max_abs_m[k], bound_m + 1e-12) << "kind " << k;
  // The noise is really there: ground and facade returns spread over a good part of the bound.
  EXPECT_GT(d.max_abs_m[0], 0.3 * bound_m);
  EXPECT_GT(d.max_abs_m[1], 0.3 * bound_m);
}

TEST(CityScan, SomeFacadeReturnsComeFromInsideWindowRecesses) {
  const auto scene = ds::make_city_scene(1);
  auto plain = scene;  // the same boxes without windows
  for (auto& box : plain.boxes) box.windows = {};
  auto settings = coarse(0.35);
  settings.range_noise_sigma_m = 0.0;
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_a;
  const auto scan = ds::scan_city(scene, pose, settings, 1, true);
  std::size_t in_recess = 0;
  for (Eigen::Index i = 0; i < scan.points.cols(); ++i) {
    const auto id = scan.surface_ids[static_cast<std::size_t>(i)];
    if (ds::surface_of(scene, id).first != SurfaceKind::box) continue;
    const Eigen::Vector3d p = to_world(pose.matrix(), scan.points.col(i));
    if (ds::surface_distance_m(plain, id, p) < -0.05) ++in_recess;  // 5 cm or more inside the plain box
  }
  std::cout << "returns inside window recesses: " << in_recess << " of " << scan.points.cols() << "\n";
  EXPECT_GT(in_recess, 500u);
}

TEST(CityScan, SameSeedSameBytesOtherSeedOtherPoints) {
  const auto scene = ds::make_city_scene(7);
  const auto settings = coarse(0.6);
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_b;
  const auto a = ds::scan_city(scene, pose, settings, 3, true);
  const auto b = ds::scan_city(ds::make_city_scene(7), pose, settings, 3, true);
  EXPECT_TRUE(same_bytes(a.points, b.points));
  EXPECT_EQ(a.surface_ids, b.surface_ids);
  const auto other_noise = ds::scan_city(scene, pose, settings, 4);
  EXPECT_FALSE(same_bytes(a.points, other_noise.points));
  const auto other_city = ds::scan_city(ds::make_city_scene(8), pose, settings, 3);
  EXPECT_FALSE(same_bytes(a.points, other_city.points));
  const auto preset = *ds::find_city_pair_preset("city-tls-60k");
  EXPECT_TRUE(same_bytes(ds::scan_city_pair(preset, true, 5).points, ds::scan_city_pair(preset, true, 5).points));
}

TEST(CityScan, ScanBMovedByTheKnownPoseLiesOnTheSurfaces) {
  const auto scene = ds::make_city_scene(1);
  const auto& poses = ds::city_pair_poses();
  const auto scan_b = ds::scan_city(scene, poses.scanner_b, coarse(), 2, true);
  const double bound_m = ds::max_range_noise_m(coarse());
  // Via A's frame: world <- A <- B, with T_A_B the pair's reference.
  const Eigen::Matrix4d T_world_b = poses.scanner_a.matrix() * poses.reference;
  EXPECT_LE((T_world_b - poses.scanner_b.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  const Deviation d = deviations(scene, scan_b, T_world_b);
  print("scan B via reference", d);
  for (int k = 0; k < 4; ++k) EXPECT_LE(d.max_abs_m[k], bound_m + 1e-9) << "kind " << k;
  // The initial guess is 0.3 m and 2 degrees off: it must not pass the same check.
  const Deviation off = deviations(scene, scan_b, poses.scanner_a.matrix() * poses.initial, 20);
  EXPECT_GT(off.max_abs_m[0], 10 * bound_m);
}

TEST(CityScan, ScanBMovedByTheKnownPoseOverlapsScanA) {
  // A dense A (0.1 degrees) and a coarse B; B's returns near the scanners, where A samples the surfaces
  // every few centimetres, must mostly find an A point within 5 cm. With the initial guess they must not.
  const auto& poses = ds::city_pair_poses();
  const auto scene = ds::make_city_scene(1);
  auto dense = coarse(0.1);
  dense.max_elevation_deg = 20.0;
  dense.max_range_m = 11.0;
  const auto scan_a = ds::scan_city(scene, poses.scanner_a, dense, 1);
  auto sparse = coarse(0.5);
  sparse.max_range_m = 10.0;
  const auto scan_b = ds::scan_city(scene, poses.scanner_b, sparse, 2);
  const auto index = nnb::make_adapter("nanoflann_kdtree");
  index->build(scan_a.points);
  const auto share_within_5cm = [&](const Eigen::Matrix4d& T_a_b) {
    nnb::Cloud moved = (T_a_b.topLeftCorner<3, 3>() * scan_b.points).colwise() + T_a_b.topRightCorner<3, 1>();
    // Only B's returns within 8 m of scanner A, where A's spacing is below 1.5 cm.
    std::vector<Eigen::Index> near;
    for (Eigen::Index i = 0; i < moved.cols(); ++i) {
      if (moved.col(i).norm() < 8.0) near.push_back(i);
    }
    nnb::Cloud queries(3, static_cast<Eigen::Index>(near.size()));
    for (std::size_t j = 0; j < near.size(); ++j) queries.col(static_cast<Eigen::Index>(j)) = moved.col(near[j]);
    nnb::Neighbours out;
    index->ranged(queries, 1, 0.05, out);
    return static_cast<double>(out.queries_with_neighbours()) / static_cast<double>(queries.cols());
  };
  const double share_reference = share_within_5cm(poses.reference);
  const double share_initial = share_within_5cm(poses.initial);
  std::cout << "A points " << scan_a.points.cols() << ", B points " << scan_b.points.cols()
            << ", share within 5 cm: reference " << share_reference << ", initial " << share_initial << "\n";
  EXPECT_GE(share_reference, 0.8);
  EXPECT_LT(share_initial, 0.5);
}

TEST(CityScan, MissesAndReturnsOutsideTheRangeWindowAreDropped) {
  const auto scene = ds::make_city_scene(1);
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_a;
  auto settings = coarse();
  const auto full = ds::scan_city(scene, pose, settings, 1);
  settings.min_range_m = 4.0;
  settings.max_range_m = 30.0;
  const auto window = ds::scan_city(scene, pose, settings, 1);
  for (const auto* scan : {&full, &window}) {
    EXPECT_EQ(scan->n_rays, ds::ray_count(settings));
    EXPECT_EQ(scan->n_rays, scan->n_dropped + static_cast<std::size_t>(scan->points.cols()));
    EXPECT_EQ(nnb::first_non_finite(scan->points), -1);
  }
  // Rays into the sky and past the end of the streets find nothing: a real share of the rays.
  EXPECT_GT(full.n_dropped, full.n_rays / 10);
  double min_range = 1e300, max_range = 0;
  for (Eigen::Index i = 0; i < window.points.cols(); ++i) {
    min_range = std::min(min_range, window.points.col(i).norm());
    max_range = std::max(max_range, window.points.col(i).norm());
  }
  EXPECT_GE(min_range, 4.0);
  EXPECT_LE(max_range, 30.0);
  EXPECT_LT(window.points.cols(), full.points.cols() * 9 / 10);
  EXPECT_GT(window.points.cols(), 0);
}

TEST(CityScan, CountsGrowWithTheSquareOfTheInverseStep) {
  const auto scene = ds::make_city_scene(1);
  const ds::ScannerPose pose = ds::city_pair_poses().scanner_a;
  EXPECT_EQ(ds::ray_count(coarse(0.5)), 720u * 201u);
  EXPECT_EQ(ds::ray_count(coarse(0.25)), 1440u * 401u);
  EXPECT_EQ(ds::ray_count(coarse(0.7)), 514u * 143u);
  const double n_coarse = static_cast<double>(ds::scan_city(scene, pose, coarse(0.5), 1).points.cols());
  const double n_fine = static_cast<double>(ds::scan_city(scene, pose, coarse(0.25), 1).points.cols());
  std::cout << "points at 0.5 deg: " << n_coarse << ", at 0.25 deg: " << n_fine << "\n";
  EXPECT_NEAR(n_fine / n_coarse, 4.0, 0.2);
}

TEST(CityScan, BadSettingsAreInputErrors) {
  const auto scene = ds::make_city_scene(1);
  const ds::ScannerPose pose;
  for (const double step : {0.0, -1.0, std::nan("")}) {
    EXPECT_THROW(ds::scan_city(scene, pose, coarse(step), 1), nnb::InputError) << step;
  }
  auto settings = coarse();
  settings.min_elevation_deg = 10;
  settings.max_elevation_deg = -10;
  EXPECT_THROW(ds::scan_city(scene, pose, settings, 1), nnb::InputError);
  settings = coarse();
  settings.max_range_m = settings.min_range_m;
  EXPECT_THROW(ds::scan_city(scene, pose, settings, 1), nnb::InputError);
  EXPECT_THROW(ds::surface_of(scene, static_cast<std::uint32_t>(scene.surface_count())), nnb::InputError);
}

TEST(CityScanCatalog, PresetsAreNamedPairsWithTheKnownPoses) {
  const auto names = ds::dataset_names();
  const auto& presets = ds::city_pair_presets();
  ASSERT_EQ(presets.size(), 6u);
  for (std::size_t i = 0; i < presets.size(); ++i) {
    EXPECT_NE(std::find(names.begin(), names.end(), presets[i].name), names.end()) << presets[i].name;
    const auto pair = ds::find_pair(presets[i].name);
    ASSERT_TRUE(pair) << presets[i].name;
    EXPECT_EQ(pair->kind, "simulated");
    if (i > 0) {
      EXPECT_NEAR(presets[i - 1].angular_step_deg / presets[i].angular_step_deg, 2.0, 1e-12);
    }
  }
  EXPECT_EQ(presets.back().name, "city-tls-16m");
  const auto pair = ds::require_pair("city-tls-60k");
  const auto& poses = ds::city_pair_poses();
  EXPECT_EQ(ds::load_pair_pose(pair, ds::PoseKind::reference, {}).value(), poses.reference);
  EXPECT_EQ(ds::load_pair_pose(pair, ds::PoseKind::initial, {}).value(), poses.initial);
  EXPECT_FALSE(ds::load_pair_pose(pair, ds::PoseKind::estimate, {}));
  // Scanners a few metres apart, 12 degrees of yaw; the initial guess 0.3 m and 2 degrees off.
  const double baseline_m = poses.reference.topRightCorner<3, 1>().norm();
  EXPECT_NEAR(baseline_m, 4.89, 0.01);
  EXPECT_NEAR(std::acos(poses.reference(0, 0)), 12.0 * kDeg, 1e-9);
  const Eigen::Matrix4d delta = poses.reference.inverse() * poses.initial;
  const double offset_m = delta.topRightCorner<3, 1>().norm();
  const double offset_rad = std::acos((delta.topLeftCorner<3, 3>().trace() - 1.0) / 2.0);
  EXPECT_NEAR(offset_m, 0.3, 1e-12);
  EXPECT_NEAR(offset_rad, 2.0 * kDeg, 1e-9);
}

TEST(CityScanCatalog, ResolveGivesScanAAsModelAndScanBMovedAsQuery) {
  ds::DataOptions options;
  options.seed = 3;
  const auto preset = *ds::find_city_pair_preset("city-tls-60k");
  const auto model = ds::resolve_cloud("city-tls-60k", ds::Role::model, options);
  const auto query = ds::resolve_cloud("city-tls-60k", ds::Role::query, options);
  EXPECT_EQ(model.kind, "simulated_pair");
  EXPECT_EQ(model.seed, 3u);
  EXPECT_TRUE(same_bytes(model.points, ds::scan_city_pair(preset, false, 3).points));
  const auto raw_b = ds::scan_city_pair(preset, true, 3);
  EXPECT_EQ(query.n_read, raw_b.n_rays);
  EXPECT_EQ(query.n_dropped, raw_b.n_dropped);
  EXPECT_EQ(query.pose, ds::city_pair_poses().reference);
  ASSERT_EQ(query.points.cols(), raw_b.points.cols());
  const nnb::Cloud expected = (query.pose.topLeftCorner<3, 3>() * raw_b.points).colwise() + query.pose.topRightCorner<3, 1>();
  EXPECT_LE((query.points - expected).cwiseAbs().maxCoeff(), 1e-12);
  const double n_model = static_cast<double>(model.points.cols()), n_query = static_cast<double>(query.points.cols());
  // About 60k points per scan (the name's promise), here with another seed than the README's.
  EXPECT_NEAR(n_model, 60000.0, 9000.0);
  EXPECT_NEAR(n_query, 60000.0, 9000.0);
}
