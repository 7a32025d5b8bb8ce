// datasets/manifest.json: the only translation unit that includes nlohmann/json.
#include "nnb/datasets/manifest.hpp"

#include "nnb/cloud.hpp"

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>

#ifndef NNB_MANIFEST_PATH
#error "NNB_MANIFEST_PATH must be defined by the build"
#endif

namespace nnb::datasets {
namespace {

using nlohmann::json;

ManifestScan parse_scan(const json& j) {
  ManifestScan scan;
  scan.file = j.at("file").get<std::string>();
  scan.format = j.at("format").get<std::string>();
  scan.sha256 = j.at("sha256").get<std::string>();
  scan.expected_points = j.at("points").get<std::size_t>();
  return scan;
}

std::optional<ManifestPose> parse_pose(const json& pair, const char* key) {
  if (!pair.contains(key) || pair.at(key).is_null()) return std::nullopt;
  const json& j = pair.at(key);
  return ManifestPose{j.at("file").get<std::string>(), j.at("format").get<std::string>(), j.at("sha256").get<std::string>()};
}

}  // namespace

std::string manifest_path() {
  const char* env = std::getenv("NNB_MANIFEST");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string(NNB_MANIFEST_PATH);
}

std::vector<RealPair> parse_manifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot open the data set manifest " + path);
  std::vector<RealPair> pairs;
  try {
    const json doc = json::parse(in);
    for (const json& j : doc.at("pairs")) {
      RealPair pair;
      pair.name = j.at("name").get<std::string>();
      pair.folder = j.at("folder").get<std::string>();
      pair.model = parse_scan(j.at("model"));
      pair.query = parse_scan(j.at("query"));
      pair.scale_to_m = j.at("scale_to_m").get<double>();
      pair.units = j.value("units", "");
      pair.reference = parse_pose(j, "reference_pose");
      pair.initial = parse_pose(j, "initial_pose");
      pair.estimate = parse_pose(j, "estimate_pose");
      pair.notes = j.value("notes", "");
      pairs.push_back(std::move(pair));
    }
  } catch (const json::exception& e) {
    throw InputError("malformed data set manifest " + path + ": " + e.what());
  }
  return pairs;
}

std::vector<RealPair> real_pairs() { return parse_manifest(manifest_path()); }

}  // namespace nnb::datasets
