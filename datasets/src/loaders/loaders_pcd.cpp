// PCD v0.7 (FORMATS.md section 3): ascii, binary and binary_compressed (LZF), read here rather than through
// PCL, which turns ascii words into 0, allocates whatever a header claims and crashes on some headers.
// Values are decoded as PCL stores them (float fields as float), so valid files load to the same points.
#include "loaders_detail.hpp"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

namespace nnb::datasets::detail {
namespace {

/// One binary value of a field's type (little-endian, as PCL writes on the hosts it runs on).
double decode_value(const char* p, char type, char size) {
  switch (size) {
    case '1': return type == 'I' ? double(static_cast<std::int8_t>(*p)) : double(static_cast<std::uint8_t>(*p));
    case '2': { std::int16_t s; std::uint16_t u; std::memcpy(&s, p, 2); std::memcpy(&u, p, 2); return type == 'I' ? s : u; }
    case '4': {
      if (type == 'F') { float f; std::memcpy(&f, p, 4); return f; }
      std::int32_t s; std::uint32_t u; std::memcpy(&s, p, 4); std::memcpy(&u, p, 4); return type == 'I' ? s : u;
    }
    default: {
      if (type == 'F') { double d; std::memcpy(&d, p, 8); return d; }
      std::int64_t s; std::uint64_t u; std::memcpy(&s, p, 8); std::memcpy(&u, p, 8);
      return type == 'I' ? static_cast<double>(s) : static_cast<double>(u);
    }
  }
}

/// What the header says, checked for consistency: field i has sizes[i] bytes, types[i] and counts[i].
struct PcdLayout {
  std::vector<std::string> fields, sizes, types;
  std::vector<unsigned long long> counts;
  unsigned long long n = 0;            ///< WIDTH x HEIGHT
  unsigned long long point_bytes = 0;  ///< sum of SIZE x COUNT
  std::string data;                    ///< ascii, binary or binary_compressed
  std::size_t payload_at = 0;          ///< first byte after the DATA line
  std::size_t payload_line = 0;        ///< line number of the first data line
};

/// LZF's densest code turns 3 bytes into 264: no honest compressed block expands more than that.
constexpr unsigned long long kLzfMaxExpansion = 88;
/// A point record larger than this is no point cloud; it also keeps every size product in 64 bits.
constexpr unsigned long long kMaxPointBytes = 1ull << 24;

InputError wrong_header(const std::string& path, const std::string& why) {
  return InputError("wrong PCD header in " + path + ": " + why);
}

/// The whole of text as an unsigned decimal number.
bool parse_count(const std::string& text, unsigned long long& out) {
  const auto r = std::from_chars(text.data(), text.data() + text.size(), out);
  return r.ec == std::errc() && r.ptr == text.data() + text.size();
}

/// The header's keyword lines as written, before they are checked against each other.
struct PcdHeaderLines {
  PcdLayout layout;                 ///< fields, sizes, types, data and where the payload starts
  std::vector<std::string> counts;  ///< COUNT's words; empty without a COUNT line
  std::optional<unsigned long long> width, height, points;
};

/// The one number of a WIDTH, HEIGHT or POINTS line.
unsigned long long header_number(const std::string& path, const std::string& key,
                                 const std::vector<std::string>& values) {
  unsigned long long number = 0;
  if (values.size() != 1) throw wrong_header(path, "bad " + key + " line");
  if (!parse_count(values[0], number)) throw wrong_header(path, "bad " + key + " value");
  return number;
}

/// Keeps what one keyword line says; VERSION and VIEWPOINT change nothing about the points read.
void read_header_line(const std::string& path, const std::string& key, std::vector<std::string> values,
                      PcdHeaderLines& header) {
  PcdLayout& layout = header.layout;
  if (key == "VERSION" || key == "VIEWPOINT") return;
  if (key == "FIELDS" || key == "COLUMNS") layout.fields = std::move(values);
  else if (key == "SIZE") layout.sizes = std::move(values);
  else if (key == "TYPE") layout.types = std::move(values);
  else if (key == "COUNT") header.counts = std::move(values);
  else if (key == "WIDTH") header.width = header_number(path, key, values);
  else if (key == "HEIGHT") header.height = header_number(path, key, values);
  else if (key == "POINTS") header.points = header_number(path, key, values);
  else if (key == "DATA") layout.data = values.empty() ? "?" : values[0];
  else throw wrong_header(path, "unknown line '" + key + "'");
}

/// Every line up to the DATA line, blank lines and comments skipped, and where the payload starts.
PcdHeaderLines read_header_lines(const std::string& path, const std::string& bytes) {
  PcdHeaderLines header;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  const char* begin = nullptr;
  const char* end = nullptr;
  while (header.layout.data.empty()) {
    if (!next_line(bytes, pos, begin, end)) throw InputError("truncated PCD header in " + path + ": no DATA line");
    ++line_no;
    std::istringstream words(std::string(begin, end));
    std::string key;
    if (!(words >> key) || key[0] == '#') continue;
    std::vector<std::string> values;
    for (std::string v; words >> v;) values.push_back(v);
    read_header_line(path, key, std::move(values), header);
  }
  header.layout.payload_at = pos;
  header.layout.payload_line = line_no + 1;
  return header;
}

/// WIDTH x HEIGHT, refused when absent, absurd, or not what POINTS says.
unsigned long long point_count(const std::string& path, const PcdHeaderLines& header) {
  if (!header.width || !header.height) throw wrong_header(path, "no WIDTH or HEIGHT");
  const unsigned long long width = *header.width, height = *header.height;
  const unsigned long long max_points = 1ull << 32;
  if (width > max_points || height > max_points || (height != 0 && width > max_points / height)) {
    throw wrong_header(path, "absurd WIDTH x HEIGHT");
  }
  if (header.points && *header.points != width * height) throw wrong_header(path, "POINTS is not WIDTH x HEIGHT");
  return width * height;
}

/// Refuses a header without fields, or whose SIZE, TYPE or COUNT does not give one entry per field.
void check_one_entry_per_field(const std::string& path, const PcdHeaderLines& header) {
  const PcdLayout& layout = header.layout;
  const std::size_t n_fields = layout.fields.size();
  if (n_fields == 0 || layout.sizes.size() != n_fields || layout.types.size() != n_fields ||
      (!header.counts.empty() && header.counts.size() != n_fields)) {
    throw wrong_header(path, "FIELDS, SIZE, TYPE and COUNT must list the same number of entries");
  }
}

/// Checks each field's SIZE, TYPE and COUNT (one value when COUNT is absent) and sums the point's bytes.
void read_field_layout(const std::string& path, const std::vector<std::string>& counts, PcdLayout& layout) {
  const auto& fields = layout.fields;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::string& size = layout.sizes[i];
    const std::string& type = layout.types[i];
    if (!(size == "1" || size == "2" || size == "4" || size == "8") || !(type == "F" || type == "U" || type == "I") ||
        (type == "F" && !(size == "4" || size == "8"))) {
      throw wrong_header(path, "bad SIZE/TYPE '" + size + " " + type + "' of field " + fields[i]);
    }
    unsigned long long count = 1;
    if (!counts.empty() && (!parse_count(counts[i], count) || count == 0 || count > 1000000)) {
      throw wrong_header(path, "bad COUNT of field " + fields[i]);
    }
    layout.counts.push_back(count);
    layout.point_bytes += count * static_cast<unsigned long long>(size[0] - '0');
    if (layout.point_bytes > kMaxPointBytes) throw wrong_header(path, "absurd point size");
  }
}

PcdLayout parse_pcd_header(const std::string& path, const std::string& bytes) {
  PcdHeaderLines header = read_header_lines(path, bytes);
  PcdLayout& layout = header.layout;
  check_one_entry_per_field(path, header);
  layout.n = point_count(path, header);
  read_field_layout(path, header.counts, layout);
  for (const char* axis : {"x", "y", "z"}) {
    if (std::find(layout.fields.begin(), layout.fields.end(), axis) == layout.fields.end()) {
      throw wrong_header(path, "no x, y and z fields");
    }
  }
  return std::move(layout);
}

/// Checks every size the header claims against the file before anything is allocated.
void check_pcd_payload(const std::string& path, const std::string& bytes, const PcdLayout& layout) {
  const unsigned long long payload = bytes.size() - layout.payload_at;
  const std::string file_size = " (file of " + std::to_string(bytes.size()) + " bytes)";
  if (layout.data == "binary") {
    require_room(path, "PCD points", layout.n, layout.point_bytes, payload);
  } else if (layout.data == "binary_compressed") {
    std::uint32_t sizes_le[2] = {0, 0};
    if (payload < 8) throw InputError("truncated PCD file " + path + ": no compressed block");
    std::memcpy(sizes_le, bytes.data() + layout.payload_at, 8);
    if (sizes_le[0] > payload - 8) {
      throw InputError("truncated PCD file " + path + ": compressed block of " + std::to_string(sizes_le[0]) +
                       " bytes, " + std::to_string(payload - 8) + " present");
    }
    if (sizes_le[1] != layout.n * layout.point_bytes) {
      throw InputError("wrong PCD header in " + path + ": uncompressed size " + std::to_string(sizes_le[1]) +
                       " does not match the " + std::to_string(layout.n) + " points claimed");
    }
    if (sizes_le[1] > kLzfMaxExpansion * sizes_le[0]) {
      throw InputError("truncated PCD file " + path + ": " + std::to_string(layout.n) + " points claimed (" +
                       std::to_string(sizes_le[1]) + " bytes) cannot come from a compressed block of " +
                       std::to_string(sizes_le[0]) + " bytes" + file_size);
    }
  } else if (layout.data == "ascii") {
    unsigned long long values = 0;
    for (const auto c : layout.counts) values += c;
    // A value takes a character and a separator; the last line may lack its '\n'.
    require_room(path, "PCD points", layout.n, 2 * values, payload + 1);
  } else {
    throw InputError("wrong PCD header in " + path + ": unknown DATA '" + layout.data + "'");
  }
}

/// Parses one ascii value of a field's type at p (after blanks), as PCL would store it; false if the
/// token is not such a number or is not followed by a blank or the line's end.
bool parse_pcd_value(const char*& p, const char* end, char type, char size, double& out) {
  const char* q = p;
  while (q < end && (*q == ' ' || *q == '\t' || *q == '\r')) ++q;
  if (q < end && *q == '+') ++q;
  std::from_chars_result r{q, std::errc::invalid_argument};
  if (type == 'F' && size == '4') {
    float v = 0;
    r = std::from_chars(q, end, v);
    out = v;
  } else if (type == 'F') {
    r = std::from_chars(q, end, out);
  } else {
    long long v = 0;
    r = std::from_chars(q, end, v);
    const int bits = 8 * (size - '0');
    const long long lo = type == 'U' ? 0 : (bits == 64 ? LLONG_MIN : -(1ll << (bits - 1)));
    const long long hi = type == 'U' ? (bits == 64 ? LLONG_MAX : (1ll << bits) - 1) : (bits == 64 ? LLONG_MAX : (1ll << (bits - 1)) - 1);
    if (r.ec == std::errc() && (v < lo || v > hi)) r.ec = std::errc::result_out_of_range;
    out = static_cast<double>(v);
  }
  if (r.ec != std::errc() || r.ptr == q) return false;
  if (r.ptr < end && !(*r.ptr == ' ' || *r.ptr == '\t' || *r.ptr == '\r')) return false;
  p = r.ptr;
  return true;
}

/// Strict ascii PCD: one line per point with every value of every field, blank lines skipped; anything
/// that is not a number of its field's type is refused with its line.
RawPoints read_ascii_pcd(const std::string& path, const std::string& bytes, const PcdLayout& layout) {
  int axis_field[3] = {-1, -1, -1};
  for (std::size_t f = 0; f < layout.fields.size(); ++f) {
    for (int a = 0; a < 3; ++a) {
      if (layout.fields[f] == std::string(1, static_cast<char>('x' + a))) axis_field[a] = static_cast<int>(f);
    }
  }
  RawPoints raw;
  raw.xyz.resize(3 * layout.n);
  std::size_t pos = layout.payload_at;
  std::size_t line_no = layout.payload_line - 1;
  const char* line = nullptr;
  const char* end = nullptr;
  auto malformed = [&](const std::string& why) {
    return InputError("malformed number in " + path + " line " + std::to_string(line_no) + " (" + why + "): '" +
                      std::string(line, std::min<std::size_t>(end - line, 60)) + "'");
  };
  unsigned long long i = 0;
  while (next_line(bytes, pos, line, end)) {
    ++line_no;
    const char* p = line;
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p == end) continue;
    if (i == layout.n) throw malformed("more lines than the " + std::to_string(layout.n) + " points claimed");
    p = line;
    for (std::size_t f = 0; f < layout.fields.size(); ++f) {
      for (unsigned long long c = 0; c < layout.counts[f]; ++c) {
        double value = 0;
        if (!parse_pcd_value(p, end, layout.types[f][0], layout.sizes[f][0], value)) {
          throw malformed("field " + layout.fields[f] + " of point " + std::to_string(i));
        }
        for (int a = 0; a < 3; ++a) {
          if (axis_field[a] == static_cast<int>(f) && c == 0) raw.xyz[3 * i + a] = value;
        }
      }
    }
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p != end) throw malformed("more values than the header's fields");
    ++i;
  }
  if (i != layout.n) {
    throw InputError("truncated PCD file " + path + ": " + std::to_string(i) + " of " + std::to_string(layout.n) +
                     " points present");
  }
  return raw;
}

/// Field index of each axis (the last field of that name, as PCL picks it) and its byte offset in a
/// record (array of structures) or in a field block (structure of arrays: n values per field).
struct AxisPlaces {
  int field[3] = {-1, -1, -1};
  unsigned long long offset[3] = {0, 0, 0};
};

AxisPlaces axis_places(const PcdLayout& layout, bool structure_of_arrays) {
  AxisPlaces places;
  unsigned long long offset = 0;
  for (std::size_t f = 0; f < layout.fields.size(); ++f) {
    for (int a = 0; a < 3; ++a) {
      if (layout.fields[f] == std::string(1, static_cast<char>('x' + a))) {
        places.field[a] = static_cast<int>(f);
        places.offset[a] = structure_of_arrays ? layout.n * offset : offset;
      }
    }
    offset += layout.counts[f] * static_cast<unsigned long long>(layout.sizes[f][0] - '0');
  }
  return places;
}

/// x y z of every point from n * point_bytes checked bytes, records or field blocks.
RawPoints read_binary_pcd(const char* data, const PcdLayout& layout, bool structure_of_arrays) {
  const AxisPlaces places = axis_places(layout, structure_of_arrays);
  RawPoints raw;
  raw.xyz.resize(3 * layout.n);
  for (unsigned long long i = 0; i < layout.n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const int f = places.field[a];
      const unsigned long long stride =
          structure_of_arrays ? layout.counts[f] * static_cast<unsigned long long>(layout.sizes[f][0] - '0') : layout.point_bytes;
      raw.xyz[3 * i + a] = decode_value(data + places.offset[a] + i * stride, layout.types[f][0], layout.sizes[f][0]);
    }
  }
  return raw;
}

/// liblzf's format (FORMATS.md), every read and write bounds-checked; the sizes were checked by
/// check_pcd_payload, so the output buffer is at most 88 times the compressed block.
std::string lzf_decompress(const std::string& path, const std::string& bytes, std::size_t at) {
  std::uint32_t sizes[2];
  std::memcpy(sizes, bytes.data() + at, 8);
  const auto* in = reinterpret_cast<const unsigned char*>(bytes.data() + at + 8);
  const std::size_t in_size = sizes[0];
  std::string out(sizes[1], '\0');
  std::size_t ip = 0, op = 0;
  auto corrupt = [&] { return InputError("corrupt compressed data in PCD file " + path + " at byte " + std::to_string(at + 8 + ip)); };
  while (ip < in_size) {
    std::size_t ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (len > in_size - ip || len > out.size() - op) throw corrupt();
      std::memcpy(&out[op], in + ip, len);
      ip += len;
      op += len;
      continue;
    }
    std::size_t len = ctrl >> 5;
    if (len == 7) {
      if (ip >= in_size) throw corrupt();
      len += in[ip++];
    }
    if (ip >= in_size) throw corrupt();
    const std::size_t back = ((ctrl & 0x1f) << 8) + in[ip++] + 1;
    len += 2;
    if (back > op || len > out.size() - op) throw corrupt();
    for (std::size_t k = 0; k < len; ++k, ++op) out[op] = out[op - back];
  }
  if (op != out.size()) {
    throw InputError("truncated PCD file " + path + ": compressed data gives " + std::to_string(op) + " of " +
                     std::to_string(out.size()) + " bytes");
  }
  return out;
}

}  // namespace

RawPoints read_pcd(const std::string& path) {
  const std::string bytes = read_file_bytes(path);
  const PcdLayout layout = parse_pcd_header(path, bytes);
  check_pcd_payload(path, bytes, layout);
  if (layout.data == "ascii") return read_ascii_pcd(path, bytes, layout);
  if (layout.data == "binary") return read_binary_pcd(bytes.data() + layout.payload_at, layout, false);
  const std::string soa = lzf_decompress(path, bytes, layout.payload_at);
  return read_binary_pcd(soa.data(), layout, true);
}

}  // namespace nnb::datasets::detail
