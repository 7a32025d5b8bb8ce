// 3DTK .3d, plain x y z text and raw float32 .bin.
#include "loaders_detail.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

namespace nnb::datasets::detail {

namespace {
bool only_blanks(const char* p, const char* end) {
  for (; p < end; ++p) {
    if (*p != ' ' && *p != '\t' && *p != '\r') return false;
  }
  return true;
}

/// The old SICK header "W x H" (two positive integers around an 'x').
bool is_resolution_header(const char* p, const char* end) {
  auto integer = [&](const char*& q) {
    while (q < end && (*q == ' ' || *q == '\t' || *q == '\r')) ++q;
    unsigned long value = 0;
    const auto r = std::from_chars(q, end, value);
    if (r.ec != std::errc() || r.ptr == q) return false;
    q = r.ptr;
    return true;
  };
  if (!integer(p)) return false;
  while (p < end && (*p == ' ' || *p == '\t')) ++p;
  if (p == end || *p != 'x') return false;
  ++p;
  return integer(p) && only_blanks(p, end);
}
}  // namespace

RawPoints read_3dtk(const std::string& /*path*/, const std::string& text) {
  // The 2009 copies start with a "360 x 225" header, skipped and counted; any other line that is not
  // 3 numbers is damage, reported by load_points with its line number. Further columns (reflectance in
  // 3DTK's uosr format) are ignored.
  RawPoints raw;
  raw.xyz.reserve(text.size() / 8);
  std::size_t pos = 0;
  std::size_t line_no = 0;
  const char* line = nullptr;
  const char* end = nullptr;
  while (next_line(text, pos, line, end)) {
    ++line_no;
    if (only_blanks(line, end)) continue;
    double v[3];
    const char* p = line;
    if (parse_number(p, end, v[0]) && parse_number(p, end, v[1]) && parse_number(p, end, v[2])) {
      raw.xyz.insert(raw.xyz.end(), v, v + 3);
    } else if (raw.xyz.empty() && raw.n_skipped_lines == 0 && is_resolution_header(line, end)) {
      ++raw.n_skipped_lines;
    } else if (raw.first_bad_line.empty()) {
      raw.first_bad_line = "line " + std::to_string(line_no) + ": '" +
                           std::string(line, std::min<std::size_t>(end - line, 60)) + "'";
    }
  }
  return raw;
}

RawPoints read_xyz_text(const std::string& path, const std::string& text) {
  // Strict: blank and '#' lines are skipped, every other line must start with 3 numbers.
  RawPoints raw;
  raw.xyz.reserve(text.size() / 8);
  std::size_t pos = 0;
  std::size_t line_no = 0;
  const char* line = nullptr;
  const char* end = nullptr;
  while (next_line(text, pos, line, end)) {
    ++line_no;
    const char* p = line;
    while (p < end && (*p == ' ' || *p == '\t')) ++p;
    if (only_blanks(p, end) || *p == '#') continue;
    double v[3];
    if (!(parse_number(p, end, v[0]) && parse_number(p, end, v[1]) && parse_number(p, end, v[2]))) {
      throw InputError("malformed number in " + path + " line " + std::to_string(line_no) +
                       " (expected x y z): '" + std::string(line, std::min<std::size_t>(end - line, 60)) + "'");
    }
    raw.xyz.insert(raw.xyz.end(), v, v + 3);
  }
  return raw;
}

RawPoints read_xyz_float32_bin(const std::string& path, const std::string& bytes) {
  if (bytes.size() % 12 != 0) {
    throw InputError("truncated float32 xyz file " + path + ": " + std::to_string(bytes.size()) +
                     " bytes is not a multiple of 12");
  }
  static_assert(sizeof(float) == 4, "float32 expected");
  const std::size_t n_values = bytes.size() / 4;
  RawPoints raw;
  raw.xyz.resize(n_values);
  const bool host_little = [] { const std::uint16_t one = 1; unsigned char b; std::memcpy(&b, &one, 1); return b == 1; }();
  for (std::size_t i = 0; i < n_values; ++i) {
    unsigned char b[4];
    std::memcpy(b, bytes.data() + 4 * i, 4);
    if (!host_little) { std::swap(b[0], b[3]); std::swap(b[1], b[2]); }
    float f;
    std::memcpy(&f, b, 4);
    raw.xyz[i] = f;
  }
  return raw;
}

}  // namespace nnb::datasets::detail
