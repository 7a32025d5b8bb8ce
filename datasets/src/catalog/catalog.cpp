// Name resolution: synthetic shapes, real pairs from the manifest, plain file paths.
#include "nnb/datasets/catalog.hpp"

#include "nnb/datasets/checksum.hpp"
#include "nnb/datasets/city_scan.hpp"
#include "nnb/datasets/loaders.hpp"
#include "nnb/datasets/poses.hpp"
#include "nnb/datasets/synthetic.hpp"

#include <cstdlib>
#include <filesystem>

#ifndef NNB_SOURCE_DIR
#error "NNB_SOURCE_DIR must be defined by the build"
#endif

namespace nnb::datasets {
namespace fs = std::filesystem;

namespace {

std::string joined_names() {
  std::string out;
  for (const auto& name : dataset_names()) out += (out.empty() ? "" : ", ") + name;
  return out;
}

std::string data_dir_of(const DataOptions& options) {
  return options.data_dir.empty() ? default_data_dir() : options.data_dir;
}

// A pair's file is missing: most often the scans were never fetched, so say how to get them.
InputError missing_pair_file(const std::string& path) {
  return InputError("missing file: " + path +
                    " (get the real scans with scripts/fetch_data.sh, or point --data-dir or NNB_DATA_DIR at them)");
}

// A simulated pair (city_scan.hpp) looks like a manifest pair without files, so every caller of
// find_pair / load_pair_scan / load_pair_pose takes it unchanged.
RealPair simulated_pair(const CityPairPreset& preset) {
  RealPair pair;
  pair.name = preset.name;
  pair.kind = "simulated";
  pair.units = "m";
  pair.notes = "simulated terrestrial scans of a synthetic city, angular step " + std::to_string(preset.angular_step_deg) +
               " deg (datasets/include/nnb/datasets/city_scan.hpp)";
  return pair;
}

NamedCloud simulated_scan(const RealPair& pair, Role role, const DataOptions& options) {
  const CityPairPreset preset = *find_city_pair_preset(pair.name);
  const bool scan_b = role == Role::query;
  CityScan scan = scan_city_pair(preset, scan_b, options.seed);
  NamedCloud cloud;
  cloud.name = pair.name;
  cloud.kind = "simulated_pair";
  cloud.source = std::string("scan_city_pair(") + pair.name + ", scan " + (scan_b ? "B" : "A") + ", seed " +
                 std::to_string(options.seed) + ")";
  cloud.seed = options.seed;
  cloud.points = std::move(scan.points);
  cloud.n_read = scan.n_rays;
  cloud.n_dropped = scan.n_dropped;
  return cloud;
}

NamedCloud from_loaded(LoadedPoints loaded) {
  NamedCloud cloud;
  cloud.points = std::move(loaded.points);
  cloud.n_read = loaded.n_read;
  cloud.n_dropped = loaded.n_non_finite + loaded.n_zero;
  cloud.n_non_finite = loaded.n_non_finite;
  cloud.n_zero = loaded.n_zero;
  return cloud;
}

}  // namespace

std::string default_data_dir() {
  // An explicit setting wins even if missing: its files are then reported missing, not silently replaced.
  const char* env = std::getenv("NNB_DATA_DIR");
  if (env != nullptr && *env != '\0') return env;
  const fs::path source(NNB_SOURCE_DIR);
  const fs::path fetched = source / "data" / "real";  // where scripts/fetch_data.sh puts them
  for (const fs::path& dir : {fetched, source.parent_path() / "shared" / "datasets" / "real"}) {
    std::error_code error;
    if (fs::is_directory(dir, error)) return dir.lexically_normal().string();
  }
  return fetched.string();
}

std::vector<std::string> dataset_names() {
  std::vector<std::string> names = shape_names();
  for (const auto& pair : real_pairs()) names.push_back(pair.name);
  for (const auto& preset : city_pair_presets()) names.push_back(preset.name);
  return names;
}

std::optional<RealPair> find_pair(const std::string& name) {
  if (const auto preset = find_city_pair_preset(name)) return simulated_pair(*preset);
  for (auto& pair : real_pairs()) {
    if (pair.name == name) return pair;
  }
  return std::nullopt;
}

RealPair require_pair(const std::string& name) {
  auto pair = find_pair(name);
  if (!pair) throw InputError("unknown data set '" + name + "' (known: " + joined_names() + ")");
  return *pair;
}

std::string pair_file_path(const RealPair& pair, const std::string& file, const DataOptions& options) {
  return (fs::path(data_dir_of(options)) / pair.folder / file).string();
}

void verify_sha256(const std::string& path, const std::string& expected_sha256) {
  if (!fs::exists(path)) throw InputError("missing file: " + path);
  const std::string actual = sha256_file(path);
  if (actual != expected_sha256) {
    throw InputError("checksum mismatch for " + path + ": expected sha256 " + expected_sha256 + ", got " + actual);
  }
}

std::optional<Eigen::Matrix4d> load_pair_pose(const RealPair& pair, PoseKind kind, const DataOptions& options) {
  if (pair.kind == "simulated") {
    if (kind == PoseKind::estimate) return std::nullopt;
    return kind == PoseKind::reference ? city_pair_poses().reference : city_pair_poses().initial;
  }
  const std::optional<ManifestPose>& entry =
      kind == PoseKind::reference ? pair.reference : kind == PoseKind::initial ? pair.initial : pair.estimate;
  if (!entry) {
    if (kind == PoseKind::initial) return Eigen::Matrix4d::Identity();
    return std::nullopt;
  }
  const std::string path = pair_file_path(pair, entry->file, options);
  if (!fs::exists(path)) throw missing_pair_file(path);
  if (options.verify_checksums) verify_sha256(path, entry->sha256);
  return load_pose(path, parse_pose_format(entry->format), pair.scale_to_m);
}

NamedCloud load_pair_scan(const RealPair& pair, Role role, const DataOptions& options) {
  if (pair.kind == "simulated") return simulated_scan(pair, role, options);
  const ManifestScan& scan = role == Role::model ? pair.model : pair.query;
  const std::string path = pair_file_path(pair, scan.file, options);
  if (!fs::exists(path)) throw missing_pair_file(path);
  const std::string sha = sha256_file(path);
  if (options.verify_checksums && sha != scan.sha256) {
    throw InputError("checksum mismatch for " + path + ": expected sha256 " + scan.sha256 + ", got " + sha);
  }
  NamedCloud cloud = from_loaded(load_points(path, parse_point_format(scan.format), pair.scale_to_m));
  if (options.verify_checksums && cloud.n_read != scan.expected_points) {
    throw InputError("read " + std::to_string(cloud.n_read) + " points from " + path + ", the manifest says " +
                     std::to_string(scan.expected_points));
  }
  cloud.name = pair.name;
  cloud.kind = "real_pair";
  cloud.source = path;
  cloud.sha256 = sha;
  return cloud;
}

NamedCloud resolve_cloud(const std::string& spec, Role role, const DataOptions& options) {
  if (const auto shape = parse_shape(spec)) {
    NamedCloud cloud;
    cloud.name = spec;
    cloud.kind = "synthetic";
    cloud.source = std::string("make_shape(") + to_string(*shape) + ", " + std::to_string(options.synthetic_points) +
                   ", seed " + std::to_string(options.seed) + ")";
    cloud.seed = options.seed;
    cloud.points = make_shape(*shape, options.synthetic_points, options.seed);
    cloud.n_read = options.synthetic_points;
    return cloud;
  }

  if (const auto pair = find_pair(spec)) {
    NamedCloud cloud = load_pair_scan(*pair, role, options);
    if (role == Role::query) {
      // The query is moved into the model frame by the best pose known: reference, else initial guess.
      auto pose = load_pair_pose(*pair, PoseKind::reference, options);
      if (!pose) pose = load_pair_pose(*pair, PoseKind::initial, options);
      cloud.pose = *pose;
      const Eigen::Matrix3d rotation = cloud.pose.topLeftCorner<3, 3>();
      const Eigen::Vector3d translation = cloud.pose.topRightCorner<3, 1>();
      cloud.points = (rotation * cloud.points).colwise() + translation;
    }
    check_coordinate_range(cloud.points, cloud.source);
    return cloud;
  }

  const bool looks_like_path = spec.find('/') != std::string::npos || fs::path(spec).has_extension();
  if (!fs::exists(spec)) {
    if (looks_like_path) throw InputError("missing file: " + spec);
    throw InputError("unknown data set '" + spec + "' (known: " + joined_names() + "; or a file path)");
  }
  const PointFormat format = options.file_format.empty() ? format_from_extension(spec) : parse_point_format(options.file_format);
  NamedCloud cloud = from_loaded(load_points(spec, format));
  cloud.name = spec;
  cloud.kind = "file";
  cloud.source = spec;
  cloud.sha256 = sha256_file(spec);
  check_coordinate_range(cloud.points, spec);
  return cloud;
}

}  // namespace nnb::datasets
