#pragma once
// The real scan pairs of datasets/manifest.json: which files, their sha256, units and poses.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace nnb::datasets {

/// One scan of a pair.
struct ManifestScan {
  std::string file;                 ///< relative to the pair's folder
  std::string format;               ///< a PointFormat name (parse_point_format)
  std::string sha256;
  std::size_t expected_points = 0;  ///< point records in the file, before dropping invalid ones
};

/// One pose file of a pair: T_model_query (maps query points into the model frame).
struct ManifestPose {
  std::string file;
  std::string format;               ///< a PoseFormat name (parse_pose_format)
  std::string sha256;
};

/// A real pair: the model (target, fixed) and the query (source, moved) scan.
struct RealPair {
  std::string name;
  std::string kind = "files";       ///< "files" (this manifest) or "simulated" (city_scan.hpp: no files, no folder)
  std::string folder;               ///< relative to the data directory
  ManifestScan model;
  ManifestScan query;
  double scale_to_m = 1.0;          ///< file units to metres, for points and pose translations
  std::string units;
  std::optional<ManifestPose> reference;  ///< ground truth, if any
  std::optional<ManifestPose> initial;    ///< initial guess; none = identity
  std::optional<ManifestPose> estimate;   ///< a non-ground-truth estimate (Kinect: our own ICP)
  std::string notes;
};

/// Path of manifest.json: env NNB_MANIFEST if set, else datasets/manifest.json of the source tree.
std::string manifest_path();
/// The pairs listed in that manifest file; InputError for a missing or malformed one.
std::vector<RealPair> parse_manifest(const std::string& path);
/// The pairs of manifest_path().
std::vector<RealPair> real_pairs();

}  // namespace nnb::datasets
