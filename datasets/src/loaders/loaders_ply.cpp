// PLY (ascii, binary little and big endian): header and the vertex element's x y z. PCL's loadPLYFile
// turns the Stanford bunny's range_grid into an organized 512x400 cloud of NaNs (204,800 points), not
// the file's 40,256 vertices, hence this small reader.
#include "loaders_detail.hpp"

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <utility>
#include <sstream>

namespace nnb::datasets::detail {
namespace {

enum class Encoding { ascii, binary_le, binary_be };

struct Property {
  std::string name;
  int size = 0;           // bytes of a value (binary)
  char kind = 'f';        // 'i' signed, 'u' unsigned, 'f' float
  bool is_list = false;
  int count_size = 0;     // list: bytes of the count
  char count_kind = 'u';
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

bool scalar_type(const std::string& t, int& size, char& kind) {
  if (t == "char" || t == "int8") { size = 1; kind = 'i'; return true; }
  if (t == "uchar" || t == "uint8") { size = 1; kind = 'u'; return true; }
  if (t == "short" || t == "int16") { size = 2; kind = 'i'; return true; }
  if (t == "ushort" || t == "uint16") { size = 2; kind = 'u'; return true; }
  if (t == "int" || t == "int32") { size = 4; kind = 'i'; return true; }
  if (t == "uint" || t == "uint32") { size = 4; kind = 'u'; return true; }
  if (t == "float" || t == "float32") { size = 4; kind = 'f'; return true; }
  if (t == "double" || t == "float64") { size = 8; kind = 'f'; return true; }
  return false;
}

bool host_is_little() {
  const std::uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// Decodes one binary value of the given size/kind; bounds are checked by the caller.
double decode(const unsigned char* p, int size, char kind, bool swap) {
  unsigned char b[8];
  std::memcpy(b, p, size);
  if (swap) {
    for (int i = 0; i < size / 2; ++i) std::swap(b[i], b[size - 1 - i]);
  }
  switch (size) {
    case 1: return kind == 'i' ? double(static_cast<std::int8_t>(b[0])) : double(b[0]);
    case 2: { std::int16_t s; std::uint16_t u; std::memcpy(&s, b, 2); std::memcpy(&u, b, 2); return kind == 'i' ? s : u; }
    case 4: {
      if (kind == 'f') { float f; std::memcpy(&f, b, 4); return f; }
      std::int32_t s; std::uint32_t u; std::memcpy(&s, b, 4); std::memcpy(&u, b, 4); return kind == 'i' ? s : u;
    }
    default: { double d; std::memcpy(&d, b, 8); return d; }
  }
}

/// The fewest bytes one item of the element can take: its scalars' sizes and its lists' count sizes in
/// binary; in ascii a character and a separator per value (a list has at least its count).
unsigned long long min_item_bytes(const Element& element, Encoding encoding) {
  unsigned long long bytes = 0;
  for (const Property& p : element.properties) {
    bytes += encoding == Encoding::ascii ? 2 : (p.is_list ? p.count_size : p.size);
  }
  return encoding == Encoding::ascii ? std::max<unsigned long long>(bytes, 1) : bytes;
}

struct Header {
  Encoding encoding = Encoding::ascii;
  std::vector<Element> elements;
  std::size_t vertex_element = 0;  // the index of "vertex" in elements
  int axis_of[3] = {-1, -1, -1};   // the vertex properties holding x, y and z
};

InputError wrong(const std::string& path, const std::string& why) {
  return InputError("wrong PLY header in " + path + ": " + why);
}

Element parse_element(const std::string& path, const std::string& text, std::istringstream& words) {
  Element e;
  std::string count, rest;
  words >> e.name >> count;
  const auto r = std::from_chars(count.data(), count.data() + count.size(), e.count);
  if (!words || r.ec != std::errc() || r.ptr != count.data() + count.size() || (words >> rest)) {
    throw wrong(path, "bad line '" + text + "'");
  }
  return e;
}

Property parse_property(const std::string& path, const std::string& text, std::istringstream& words) {
  Property p;
  std::string type;
  words >> type;
  if (type == "list") {
    std::string count_type, item_type;
    words >> count_type >> item_type >> p.name;
    p.is_list = true;
    if (!scalar_type(count_type, p.count_size, p.count_kind) || !scalar_type(item_type, p.size, p.kind)) {
      throw wrong(path, "bad list property '" + text + "'");
    }
  } else {
    words >> p.name;
    if (!scalar_type(type, p.size, p.kind)) throw wrong(path, "unknown property type in '" + text + "'");
  }
  if (!words) throw wrong(path, "bad property line '" + text + "'");
  return p;
}

Encoding parse_format(const std::string& path, std::istringstream& words) {
  std::string enc;
  words >> enc;
  if (enc == "ascii") return Encoding::ascii;
  if (enc == "binary_little_endian") return Encoding::binary_le;
  if (enc == "binary_big_endian") return Encoding::binary_be;
  throw wrong(path, "unknown format '" + enc + "'");
}

// The vertex element and its x, y, z properties; InputError when there are none.
void find_vertices(const std::string& path, Header& h) {
  h.vertex_element = h.elements.size();
  for (std::size_t i = 0; i < h.elements.size(); ++i) {
    if (h.elements[i].name == "vertex") { h.vertex_element = i; break; }
  }
  if (h.vertex_element == h.elements.size()) throw wrong(path, "no vertex element");
  const Element& vertex = h.elements[h.vertex_element];
  for (std::size_t i = 0; i < vertex.properties.size(); ++i) {
    const Property& p = vertex.properties[i];
    for (int a = 0; a < 3; ++a) {
      if (p.name == std::string(1, static_cast<char>('x' + a)) && !p.is_list) h.axis_of[a] = static_cast<int>(i);
    }
  }
  if (h.axis_of[0] < 0 || h.axis_of[1] < 0 || h.axis_of[2] < 0) throw wrong(path, "vertex has no x, y and z properties");
}

// The header up to end_header; pos is left at the first byte after it.
Header parse_header(const std::string& path, const std::string& bytes, std::size_t& pos) {
  if (bytes.compare(0, 4, "ply\n") != 0 && bytes.compare(0, 5, "ply\r\n") != 0) throw wrong(path, "does not start with 'ply'");
  const char* line = nullptr;
  const char* end = nullptr;
  next_line(bytes, pos, line, end);
  Header h;
  bool have_format = false, have_end = false;
  while (next_line(bytes, pos, line, end)) {
    std::string text(line, end);
    if (!text.empty() && text.back() == '\r') text.pop_back();
    std::istringstream words(text);
    std::string key;
    words >> key;
    if (key == "end_header") { have_end = true; break; }
    if (key == "comment" || key == "obj_info" || key.empty()) continue;
    if (key == "format") {
      h.encoding = parse_format(path, words);
      have_format = true;
    } else if (key == "element") {
      h.elements.push_back(parse_element(path, text, words));
    } else if (key == "property") {
      if (h.elements.empty()) throw wrong(path, "property before any element");
      h.elements.back().properties.push_back(parse_property(path, text, words));
    } else {
      throw wrong(path, "unknown header line '" + text + "'");
    }
  }
  if (!have_end) throw InputError("truncated PLY header in " + path + ": no end_header");
  if (!have_format) throw wrong(path, "no format line");
  find_vertices(path, h);
  return h;
}

// One ascii vertex line into raw.xyz[3 i ...].
void read_ascii_vertex(const std::string& path, const Header& h, const char* line, const char* end, std::size_t i,
                       RawPoints& raw) {
  const Element& vertex = h.elements[h.vertex_element];
  const char* p = line;
  for (std::size_t k = 0; k < vertex.properties.size(); ++k) {
    const Property& prop = vertex.properties[k];
    double value = 0;
    std::size_t n_values = 1;
    if (prop.is_list) {
      if (!parse_number(p, end, value) || !(value >= 0 && value < 1e9)) n_values = static_cast<std::size_t>(-1);
      else n_values = static_cast<std::size_t>(value);
    }
    bool ok = n_values != static_cast<std::size_t>(-1);
    for (std::size_t v = 0; ok && v < n_values; ++v) ok = parse_number(p, end, value);
    if (!ok) {
      throw InputError("malformed number in " + path + " at vertex " + std::to_string(i) + " ('" +
                       std::string(line, std::min<std::size_t>(end - line, 60)) + "')");
    }
    for (int a = 0; a < 3; ++a) {
      if (h.axis_of[a] == static_cast<int>(k)) raw.xyz[3 * i + a] = value;
    }
  }
  while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
  if (p != end) {
    throw InputError("malformed number in " + path + " at vertex " + std::to_string(i) + ": more values than " +
                     "the header's properties ('" + std::string(line, std::min<std::size_t>(end - line, 60)) + "')");
  }
}

// One line per element item; elements before the vertices are skipped line by line.
void read_ascii(const std::string& path, const std::string& bytes, std::size_t pos, const Header& h, RawPoints& raw) {
  const char* line = nullptr;
  const char* end = nullptr;
  for (std::size_t e = 0; e <= h.vertex_element; ++e) {
    for (std::size_t i = 0; i < h.elements[e].count; ++i) {
      if (!next_line(bytes, pos, line, end)) {
        throw InputError("truncated PLY file " + path + ": " + h.elements[e].name + " " + std::to_string(i) +
                         " of " + std::to_string(h.elements[e].count) + " missing");
      }
      if (e == h.vertex_element) read_ascii_vertex(path, h, line, end, i, raw);
    }
  }
}

void read_binary(const std::string& path, const std::string& bytes, std::size_t pos, const Header& h, RawPoints& raw) {
  const bool swap = (h.encoding == Encoding::binary_le) != host_is_little();
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  std::size_t at = pos;
  auto need = [&](std::size_t n, const Element& e, std::size_t i) {
    if (n > bytes.size() - at) {
      throw InputError("truncated PLY file " + path + ": data ends in " + e.name + " " + std::to_string(i) +
                       " of " + std::to_string(e.count));
    }
  };
  for (std::size_t e = 0; e <= h.vertex_element; ++e) {
    const Element& el = h.elements[e];
    const bool is_vertex = e == h.vertex_element;
    if (el.properties.empty()) continue;  // no bytes to read, whatever the count
    for (std::size_t i = 0; i < el.count; ++i) {
      for (std::size_t k = 0; k < el.properties.size(); ++k) {
        const Property& prop = el.properties[k];
        std::size_t n_values = 1;
        if (prop.is_list) {
          need(prop.count_size, el, i);
          const double n = decode(data + at, prop.count_size, prop.count_kind, swap);
          at += prop.count_size;
          if (!(n >= 0 && n < 4294967296.0)) throw InputError("malformed list count in " + path + " (" + el.name + ")");
          n_values = static_cast<std::size_t>(n);
        }
        if (n_values > (bytes.size() - at) / static_cast<std::size_t>(prop.size)) need(bytes.size() - at + 1, el, i);
        if (is_vertex && !prop.is_list) {
          const double value = decode(data + at, prop.size, prop.kind, swap);
          for (int a = 0; a < 3; ++a) {
            if (h.axis_of[a] == static_cast<int>(k)) raw.xyz[3 * i + a] = value;
          }
        }
        at += n_values * prop.size;
      }
    }
  }
}

}  // namespace

RawPoints read_ply(const std::string& path, const std::string& bytes) {
  std::size_t pos = 0;
  const Header h = parse_header(path, bytes, pos);
  // Every count is checked against the bytes after the header before anything is allocated for it.
  for (std::size_t e = 0; e <= h.vertex_element; ++e) {
    const std::string what = "PLY " + h.elements[e].name + " items";
    const std::size_t slack = h.encoding == Encoding::ascii ? 1 : 0;  // the last line may lack its '\n'
    require_room(path, what.c_str(), h.elements[e].count, min_item_bytes(h.elements[e], h.encoding),
                 bytes.size() - pos + slack);
  }
  RawPoints raw;
  raw.xyz.resize(3 * h.elements[h.vertex_element].count);
  if (h.encoding == Encoding::ascii) read_ascii(path, bytes, pos, h, raw);
  else read_binary(path, bytes, pos, h, raw);
  return raw;
}

}  // namespace nnb::datasets::detail
