#pragma once
// Readers for the real scan formats (see ../shared/datasets/real/FORMATS.md): 3DTK .3d, PCD (ascii,
// binary, binary_compressed), PLY ascii/binary, raw float32 xyz .bin and plain x y z text. Every reader
// returns the valid points in metres and counts what it dropped; bad input throws nnb::InputError with
// one line, and no header's count is believed before the file's size confirms it.
#include "nnb/cloud.hpp"

#include <cstddef>
#include <string>

namespace nnb::datasets {

enum class PointFormat { by_extension, tdtk_3d, pcd, ply, xyz_float32_bin, xyz_text };

/// The format of that name: "3dtk-3d"/"3d", "pcd", "ply", "xyz-float32-bin"/"bin", "xyz-text"/"xyz"/"txt".
PointFormat parse_point_format(const std::string& name);
/// The canonical name of a format, as written in manifest.json.
const char* to_string(PointFormat format);
/// The format implied by the path's extension (.3d .pcd .ply .bin .xyz .txt); InputError for any other.
PointFormat format_from_extension(const std::string& path);
/// Factor from the format's native unit to metres: 0.01 for 3DTK .3d (centimetres), else 1.
double default_scale_to_m(PointFormat format);

struct LoadedPoints {
  Cloud points;                      ///< metres, invalid points dropped, file order kept
  PointFormat format = PointFormat::by_extension;  ///< the format actually read
  std::size_t n_read = 0;            ///< point records in the file, valid or not
  std::size_t n_non_finite = 0;      ///< dropped: a NaN or infinite coordinate
  std::size_t n_zero = 0;            ///< dropped: exact (0,0,0) placeholders
  std::size_t n_skipped_lines = 0;   ///< 3DTK .3d only: lines that are not 3 numbers (the old header)
};

/// Reads a point file; coordinates are multiplied by scale_to_m (0 = default_scale_to_m(format)).
/// Throws InputError naming the file when it is missing, unreadable, empty, truncated, has a wrong
/// header or a malformed number, or has no valid point left after dropping invalid ones.
LoadedPoints load_points(const std::string& path, PointFormat format = PointFormat::by_extension,
                         double scale_to_m = 0.0);

}  // namespace nnb::datasets
