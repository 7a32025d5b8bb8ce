#pragma once
// Internal to the loaders: reading a file's bytes, parsing numbers, and the per-format readers that
// return raw coordinates in file units (validity filtering and scaling happen once, in loaders.cpp).
#include "nnb/cloud.hpp"

#include <charconv>
#include <cstddef>
#include <string>
#include <vector>

namespace nnb::datasets::detail {

/// Coordinates x0 y0 z0 x1 ... in file units, all records (valid or not).
struct RawPoints {
  std::vector<double> xyz;
  std::size_t n_skipped_lines = 0;
  std::string first_bad_line;  ///< "line N: 'text'" of the first damaged line, refused by load_points
};

/// Throws the truncation InputError when n_items items of at least min_bytes each cannot fit in
/// available bytes: every count a header claims is checked before anything is allocated for it.
void require_room(const std::string& path, const char* what, unsigned long long n_items, unsigned long long min_bytes,
                  unsigned long long available);

/// The file's bytes; InputError for a missing, unreadable or empty file.
std::string read_file_bytes(const std::string& path);
/// InputError for a missing or empty file (for readers that open the file themselves).
void require_nonempty_file(const std::string& path);

/// Skips blanks (space, tab, \r) and parses one number at p (leading '+' allowed; nan/inf accepted).
/// Returns false, p unchanged, if there is no number followed by a blank or end of range.
inline bool parse_number(const char*& p, const char* end, double& out) {
  const char* q = p;
  while (q < end && (*q == ' ' || *q == '\t' || *q == '\r')) ++q;
  if (q < end && *q == '+') ++q;
  const auto result = std::from_chars(q, end, out);
  if (result.ec != std::errc() || result.ptr == q) return false;
  if (result.ptr < end && !(*result.ptr == ' ' || *result.ptr == '\t' || *result.ptr == '\r')) return false;
  p = result.ptr;
  return true;
}

/// One line [begin, end) without its '\n'; advances pos past the '\n'.
inline bool next_line(const std::string& text, std::size_t& pos, const char*& begin, const char*& end) {
  if (pos >= text.size()) return false;
  const std::size_t nl = text.find('\n', pos);
  const std::size_t stop = nl == std::string::npos ? text.size() : nl;
  begin = text.data() + pos;
  end = text.data() + stop;
  pos = nl == std::string::npos ? text.size() : nl + 1;
  return true;
}

RawPoints read_3dtk(const std::string& path, const std::string& text);
RawPoints read_xyz_text(const std::string& path, const std::string& text);
RawPoints read_xyz_float32_bin(const std::string& path, const std::string& bytes);
RawPoints read_ply(const std::string& path, const std::string& bytes);
/// ascii, binary and binary_compressed PCD, every size checked against the file first.
RawPoints read_pcd(const std::string& path);

}  // namespace nnb::datasets::detail
