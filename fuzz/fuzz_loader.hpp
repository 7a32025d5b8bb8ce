#pragma once
// Shared by the loader fuzz targets: the bytes go to a temporary file (the loaders read files) and the
// loader runs on it. InputError is the expected refusal; anything else escapes and is a finding.
#include "nnb/datasets/loaders.hpp"

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace nnb::fuzz {

inline std::string scratch_path(const char* extension) {
  return (std::filesystem::temp_directory_path() / ("nnb_fuzz_" + std::to_string(::getpid()) + extension)).string();
}

inline void write_bytes(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, file) != size) std::abort();
  std::fclose(file);
}

/// Loads the bytes as a file of that format; the cloud must then pass the coordinate check or refuse.
inline int load_bytes(const std::uint8_t* data, std::size_t size, datasets::PointFormat format, const char* extension) {
  const std::string path = scratch_path(extension);
  write_bytes(path, data, size);
  try {
    const auto loaded = datasets::load_points(path, format);
    if (loaded.points.cols() == 0) std::abort();  // the loaders promise at least one point
    check_coordinate_range(loaded.points, path);
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace nnb::fuzz
