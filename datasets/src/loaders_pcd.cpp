// PCD through PCL (ascii, binary, binary_compressed). The only translation unit that includes PCL.
// PCL's own error prints are silenced for the call: the InputError thrown here is the one line.
#include "loaders_detail.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cstring>
#include <sstream>
#include <vector>

namespace nnb::datasets::detail {
namespace {

/// Restores PCL's verbosity on every way out.
class QuietPcl {
 public:
  QuietPcl() : saved_(pcl::console::getVerbosityLevel()) { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }
  ~QuietPcl() { pcl::console::setVerbosityLevel(saved_); }
  QuietPcl(const QuietPcl&) = delete;
  QuietPcl& operator=(const QuietPcl&) = delete;

 private:
  pcl::console::VERBOSITY_LEVEL saved_;
};

double read_field(const std::uint8_t* p, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: { std::int8_t v; std::memcpy(&v, p, 1); return v; }
    case pcl::PCLPointField::UINT8: { std::uint8_t v; std::memcpy(&v, p, 1); return v; }
    case pcl::PCLPointField::INT16: { std::int16_t v; std::memcpy(&v, p, 2); return v; }
    case pcl::PCLPointField::UINT16: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
    case pcl::PCLPointField::INT32: { std::int32_t v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::UINT32: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::FLOAT32: { float v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::FLOAT64: { double v; std::memcpy(&v, p, 8); return v; }
    default: return 0.0;
  }
}

int field_bytes(std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: case pcl::PCLPointField::UINT8: return 1;
    case pcl::PCLPointField::INT16: case pcl::PCLPointField::UINT16: return 2;
    case pcl::PCLPointField::INT32: case pcl::PCLPointField::UINT32: case pcl::PCLPointField::FLOAT32: return 4;
    case pcl::PCLPointField::FLOAT64: return 8;
    default: return 0;
  }
}

/// Validates the header and the payload size before PCL sees the file: PCL 1.13 crashes on some
/// malformed headers (for example one without FIELDS) instead of returning an error.
void check_pcd_layout(const std::string& path, const std::string& bytes) {
  auto wrong = [&](const std::string& why) { return InputError("wrong PCD header in " + path + ": " + why); };
  std::vector<std::string> fields, sizes, types, counts;
  unsigned long long width = 0, height = 0, points = 0;
  bool have_width = false, have_height = false, have_points = false;
  std::string data;
  std::size_t pos = 0;
  const char* begin = nullptr;
  const char* end = nullptr;
  while (data.empty()) {
    if (!next_line(bytes, pos, begin, end)) throw InputError("truncated PCD header in " + path + ": no DATA line");
    std::istringstream words(std::string(begin, end));
    std::string key;
    if (!(words >> key) || key[0] == '#') continue;
    std::vector<std::string> values;
    for (std::string v; words >> v;) values.push_back(v);
    auto number = [&](unsigned long long& out) {
      if (values.size() != 1) throw wrong("bad " + key + " line");
      const auto r = std::from_chars(values[0].data(), values[0].data() + values[0].size(), out);
      if (r.ec != std::errc() || r.ptr != values[0].data() + values[0].size()) throw wrong("bad " + key + " value");
    };
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "COLUMNS") fields = values;
    else if (key == "SIZE") sizes = values;
    else if (key == "TYPE") types = values;
    else if (key == "COUNT") counts = values;
    else if (key == "WIDTH") { number(width); have_width = true; }
    else if (key == "HEIGHT") { number(height); have_height = true; }
    else if (key == "POINTS") { number(points); have_points = true; }
    else if (key == "DATA") data = values.empty() ? "?" : values[0];
    else throw wrong("unknown line '" + key + "'");
  }
  if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size() ||
      (!counts.empty() && counts.size() != fields.size())) {
    throw wrong("FIELDS, SIZE, TYPE and COUNT must list the same number of entries");
  }
  if (!have_width || !have_height) throw wrong("no WIDTH or HEIGHT");
  if (width > (1ull << 32) || height > (1ull << 32) || width * height > (1ull << 32)) throw wrong("absurd WIDTH x HEIGHT");
  if (have_points && points != width * height) throw wrong("POINTS is not WIDTH x HEIGHT");
  unsigned long long point_bytes = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::string& size = sizes[i];
    const std::string& type = types[i];
    if (!(size == "1" || size == "2" || size == "4" || size == "8") || !(type == "F" || type == "U" || type == "I") ||
        (type == "F" && !(size == "4" || size == "8"))) {
      throw wrong("bad SIZE/TYPE '" + size + " " + type + "' of field " + fields[i]);
    }
    unsigned long long count = 1;
    if (!counts.empty()) {
      const auto r = std::from_chars(counts[i].data(), counts[i].data() + counts[i].size(), count);
      if (r.ec != std::errc() || count == 0 || count > 1000000) throw wrong("bad COUNT of field " + fields[i]);
    }
    point_bytes += count * (size[0] - '0');
  }
  for (const char* axis : {"x", "y", "z"}) {
    if (std::find(fields.begin(), fields.end(), axis) == fields.end()) throw wrong("no x, y and z fields");
  }
  const unsigned long long n = width * height;
  const unsigned long long payload = bytes.size() - pos;
  if (data == "binary") {
    if (payload < n * point_bytes) {
      throw InputError("truncated PCD file " + path + ": " + std::to_string(payload) + " data bytes for " +
                       std::to_string(n) + " points of " + std::to_string(point_bytes) + " bytes");
    }
  } else if (data == "binary_compressed") {
    std::uint32_t sizes_le[2] = {0, 0};
    if (payload < 8) throw InputError("truncated PCD file " + path + ": no compressed block");
    std::memcpy(sizes_le, bytes.data() + pos, 8);
    if (sizes_le[0] > payload - 8) {
      throw InputError("truncated PCD file " + path + ": compressed block of " + std::to_string(sizes_le[0]) +
                       " bytes, " + std::to_string(payload - 8) + " present");
    }
    if (sizes_le[1] != n * point_bytes) throw wrong("uncompressed size does not match the points");
  } else if (data != "ascii") {
    throw wrong("unknown DATA '" + data + "'");
  }
}

}  // namespace

RawPoints read_pcd(const std::string& path) {
  check_pcd_layout(path, read_file_bytes(path));
  pcl::PCLPointCloud2 cloud;
  {
    const QuietPcl quiet;
    pcl::PCDReader reader;
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_index = 0;
    try {
      if (reader.readHeader(path, cloud, origin, orientation, version, data_type, data_index) < 0) {
        throw InputError("wrong PCD header in " + path);
      }
      if (reader.read(path, cloud) < 0) {
        throw InputError("cannot read the data of PCD file " + path + " (truncated or corrupt)");
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {  // pcl::PCLException and std::bad_alloc from absurd headers
      throw InputError("cannot read PCD file " + path + ": " + e.what());
    }
  }

  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  int offset[3] = {-1, -1, -1};
  std::uint8_t type[3] = {0, 0, 0};
  for (const auto& field : cloud.fields) {
    for (int a = 0; a < 3; ++a) {
      if (field.name == std::string(1, static_cast<char>('x' + a))) {
        offset[a] = static_cast<int>(field.offset);
        type[a] = field.datatype;
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (offset[a] < 0 || field_bytes(type[a]) == 0) {
      throw InputError("wrong PCD header in " + path + ": no numeric x, y and z fields");
    }
    if (static_cast<std::size_t>(offset[a] + field_bytes(type[a])) > cloud.point_step) {
      throw InputError("wrong PCD header in " + path + ": field outside the point record");
    }
  }
  if (cloud.data.size() < n * cloud.point_step) {
    throw InputError("truncated PCD file " + path + ": " + std::to_string(cloud.data.size()) + " bytes of data for " +
                     std::to_string(n) + " points");
  }

  RawPoints raw;
  raw.xyz.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* record = cloud.data.data() + i * cloud.point_step;
    for (int a = 0; a < 3; ++a) raw.xyz[3 * i + a] = read_field(record + offset[a], type[a]);
  }
  return raw;
}

}  // namespace nnb::datasets::detail
