#pragma once
// Every data set by name: the four synthetic shapes, the real pairs of datasets/manifest.json, and
// plain file paths. This is what nns_query, run_sweep and run_icp accept for --model and --query.
#include "nnb/cloud.hpp"
#include "nnb/datasets/manifest.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nnb::datasets {

enum class Role { model, query };

struct DataOptions {
  std::string data_dir;                 ///< real scans; empty = default_data_dir()
  std::size_t synthetic_points = 60000; ///< points per synthetic set (the paper's 60,000)
  std::uint64_t seed = 1;               ///< seed of every synthetic set
  bool verify_checksums = true;         ///< check every real file against its sha256 in the manifest
  std::string file_format;              ///< plain file paths: a PointFormat name; empty = by extension
};

/// A cloud ready to search, with where it came from.
struct NamedCloud {
  std::string name;         ///< the spec it was resolved from (shape, pair or path)
  std::string kind;         ///< "synthetic", "real_pair", "simulated_pair" or "file"
  std::string source;       ///< file path(s) read, or the generator and seed
  std::string sha256;       ///< of the file read (empty for synthetic sets)
  std::uint64_t seed = 0;   ///< synthetic sets and simulated pairs only
  Cloud points;             ///< metres, invalid points dropped
  std::size_t n_read = 0;   ///< points in the source before dropping
  std::size_t n_dropped = 0;///< non-finite or (0,0,0) placeholder points dropped (simulated: rays without return)
  std::size_t n_non_finite = 0;  ///< of those, with a NaN or infinite coordinate (files only)
  std::size_t n_zero = 0;        ///< of those, exact (0,0,0) placeholders (files only)
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  ///< applied to the points (query of a real pair)
};

/// The real scans' directory when DataOptions.data_dir is empty: NNB_DATA_DIR if set; else the first that
/// exists of data/real in the source tree (where scripts/fetch_data.sh puts them) and ../shared/datasets/real
/// beside it; else data/real, whose missing files then name scripts/fetch_data.sh.
std::string default_data_dir();
/// Names of the synthetic shapes, real pairs and simulated pairs, for help texts and errors.
std::vector<std::string> dataset_names();

/// Resolves a shape name, a pair name (as model: the pair's model scan; as query: the pair's query scan
/// moved by the pair's reference pose, or its initial pose when there is none) or a file path. Pairs are
/// the manifest's real pairs and the simulated city-tls-* pairs (city_scan.hpp, generated with options.seed).
/// Throws InputError with one line for an unknown name, a missing, malformed or mismatching file, or
/// a cloud left empty after dropping invalid points.
NamedCloud resolve_cloud(const std::string& spec, Role role, const DataOptions& options);

/// Which pose of a real pair: ground truth, initial guess, or a non-ground-truth estimate.
enum class PoseKind { reference, initial, estimate };

/// The pair of that name (simulated city-tls-*, else from the manifest), or nothing.
std::optional<RealPair> find_pair(const std::string& name);
/// The real pair of that name; InputError listing the known names if there is none.
RealPair require_pair(const std::string& name);
/// Full path of a file of the pair: data_dir (or default_data_dir()) / folder / file.
std::string pair_file_path(const RealPair& pair, const std::string& file, const DataOptions& options);
/// Throws InputError naming the file, expected and actual hash if the file's sha256 differs.
void verify_sha256(const std::string& path, const std::string& expected_sha256);
/// The pair's pose of that kind as T_model_query with translation in metres (file sha256-checked when
/// options.verify_checksums). Nothing when the pair lists none, except initial: identity then.
std::optional<Eigen::Matrix4d> load_pair_pose(const RealPair& pair, PoseKind kind, const DataOptions& options);
/// The pair's model scan (Role::model) or query scan (Role::query) as read, in metres, not moved.
NamedCloud load_pair_scan(const RealPair& pair, Role role, const DataOptions& options);

}  // namespace nnb::datasets
