// Format choice, file reading, and the one place invalid points are dropped and units converted.
#include "nnb/datasets/loaders.hpp"

#include "loaders_detail.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace nnb::datasets {
namespace fs = std::filesystem;

namespace detail {

void require_nonempty_file(const std::string& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) throw InputError("missing file: " + path);
  if (!fs::is_regular_file(status)) throw InputError("not a regular file: " + path);
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError("unreadable file: " + path);
  if (size == 0) throw InputError("empty file: " + path);
}

std::string read_file_bytes(const std::string& path) {
  require_nonempty_file(path);
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw InputError("unreadable file: " + path);
  std::string bytes(fs::file_size(path), '\0');
  const std::size_t got = std::fread(bytes.data(), 1, bytes.size(), file.get());
  if (got != bytes.size() || std::ferror(file.get())) throw InputError("unreadable file: " + path);
  return bytes;
}

void require_room(const std::string& path, const char* what, unsigned long long n_items, unsigned long long min_bytes,
                  unsigned long long available) {
  if (min_bytes == 0 || n_items <= available / min_bytes) return;
  throw InputError("truncated file " + path + ": " + std::to_string(n_items) + " " + what + " claimed, but " +
                   std::to_string(available) + " bytes cannot hold them (at least " + std::to_string(min_bytes) +
                   " bytes each)");
}

}  // namespace detail

PointFormat parse_point_format(const std::string& name) {
  if (name == "3dtk-3d" || name == "3d") return PointFormat::tdtk_3d;
  if (name == "pcd") return PointFormat::pcd;
  if (name == "ply") return PointFormat::ply;
  if (name == "xyz-float32-bin" || name == "bin") return PointFormat::xyz_float32_bin;
  if (name == "xyz-text" || name == "xyz" || name == "txt") return PointFormat::xyz_text;
  throw InputError("unknown point format '" + name + "' (known: 3dtk-3d, pcd, ply, xyz-float32-bin, xyz-text)");
}

const char* to_string(PointFormat format) {
  switch (format) {
    case PointFormat::by_extension: return "by-extension";
    case PointFormat::tdtk_3d: return "3dtk-3d";
    case PointFormat::pcd: return "pcd";
    case PointFormat::ply: return "ply";
    case PointFormat::xyz_float32_bin: return "xyz-float32-bin";
    case PointFormat::xyz_text: return "xyz-text";
  }
  return "?";
}

PointFormat format_from_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".3d") return PointFormat::tdtk_3d;
  if (ext == ".pcd") return PointFormat::pcd;
  if (ext == ".ply") return PointFormat::ply;
  if (ext == ".bin") return PointFormat::xyz_float32_bin;
  if (ext == ".xyz" || ext == ".txt") return PointFormat::xyz_text;
  throw InputError("cannot tell the format of '" + path + "' from its extension (known: .3d .pcd .ply .bin .xyz .txt)");
}

double default_scale_to_m(PointFormat format) { return format == PointFormat::tdtk_3d ? 0.01 : 1.0; }

LoadedPoints load_points(const std::string& path, PointFormat format, double scale_to_m) {
  if (format == PointFormat::by_extension) format = format_from_extension(path);
  if (scale_to_m == 0.0) scale_to_m = default_scale_to_m(format);
  if (!(scale_to_m > 0.0) || !std::isfinite(scale_to_m)) {
    throw InputError("scale_to_m must be a positive number for " + path);
  }

  detail::RawPoints raw;
  switch (format) {
    case PointFormat::tdtk_3d: raw = detail::read_3dtk(path, detail::read_file_bytes(path)); break;
    case PointFormat::xyz_text: raw = detail::read_xyz_text(path, detail::read_file_bytes(path)); break;
    case PointFormat::xyz_float32_bin: raw = detail::read_xyz_float32_bin(path, detail::read_file_bytes(path)); break;
    case PointFormat::ply: raw = detail::read_ply(path, detail::read_file_bytes(path)); break;
    case PointFormat::pcd: raw = detail::read_pcd(path); break;
    case PointFormat::by_extension: break;
  }

  LoadedPoints out;
  out.format = format;
  out.n_read = raw.xyz.size() / 3;
  out.n_skipped_lines = raw.n_skipped_lines;
  out.points.resize(3, static_cast<Eigen::Index>(out.n_read));
  Eigen::Index kept = 0;
  for (std::size_t i = 0; i < out.n_read; ++i) {
    const double x = raw.xyz[3 * i], y = raw.xyz[3 * i + 1], z = raw.xyz[3 * i + 2];
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      ++out.n_non_finite;
    } else if (x == 0.0 && y == 0.0 && z == 0.0) {
      ++out.n_zero;
    } else {
      out.points.col(kept++) << x * scale_to_m, y * scale_to_m, z * scale_to_m;
    }
  }
  out.points.conservativeResize(3, kept);
  if (kept == 0) {
    throw InputError("no valid point in " + path + " (" + std::to_string(out.n_read) + " read, " +
                     std::to_string(out.n_non_finite) + " non-finite, " + std::to_string(out.n_zero) +
                     " at (0,0,0)" + (raw.first_bad_line.empty() ? "" : "; malformed " + raw.first_bad_line) + ")");
  }
  if (!raw.first_bad_line.empty()) {
    throw InputError("malformed line in " + path + " " + raw.first_bad_line + " (expected x y z)");
  }
  return out;
}

}  // namespace nnb::datasets
