// Pose files: 3DTK .pose and .frames (column-major OpenGL layout, see FORMATS.md §2) and 4x4 text.
#include "nnb/datasets/poses.hpp"

#include "loaders_detail.hpp"

#include <Eigen/LU>

#include <cmath>

namespace nnb::datasets {
namespace {

/// All numbers of one line; InputError naming the file if a token is not a number.
std::vector<double> numbers_of_line(const std::string& path, std::size_t line_no, const char* p, const char* end) {
  std::vector<double> values;
  double v = 0;
  while (detail::parse_number(p, end, v)) values.push_back(v);
  while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
  if (p != end) throw InputError("malformed number in " + path + " line " + std::to_string(line_no));
  return values;
}

/// Numbers per non-blank line.
std::vector<std::vector<double>> numeric_lines(const std::string& path) {
  const std::string text = detail::read_file_bytes(path);
  std::vector<std::vector<double>> lines;
  std::size_t pos = 0, line_no = 0;
  const char* begin = nullptr;
  const char* end = nullptr;
  while (detail::next_line(text, pos, begin, end)) {
    ++line_no;
    auto values = numbers_of_line(path, line_no, begin, end);
    if (!values.empty()) lines.push_back(std::move(values));
  }
  return lines;
}

void check_matrix(const std::string& path, const Eigen::Matrix4d& m) {
  if (!m.allFinite()) throw InputError("non-finite value in pose file " + path);
  if (m(3, 0) != 0.0 || m(3, 1) != 0.0 || m(3, 2) != 0.0 || m(3, 3) != 1.0) {
    throw InputError("pose in " + path + " has a last row other than 0 0 0 1");
  }
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-4) || !(r.determinant() > 0)) {
    throw InputError("pose in " + path + " is not a rotation (R^T R != I or det <= 0)");
  }
}

}  // namespace

PoseFormat parse_pose_format(const std::string& name) {
  if (name == "3dtk-pose") return PoseFormat::tdtk_pose;
  if (name == "3dtk-frames") return PoseFormat::tdtk_frames;
  if (name == "4x4-row-major-text") return PoseFormat::matrix4_row_major;
  throw InputError("unknown pose format '" + name + "' (known: 3dtk-pose, 3dtk-frames, 4x4-row-major-text)");
}

const char* to_string(PoseFormat format) {
  switch (format) {
    case PoseFormat::tdtk_pose: return "3dtk-pose";
    case PoseFormat::tdtk_frames: return "3dtk-frames";
    case PoseFormat::matrix4_row_major: return "4x4-row-major-text";
  }
  return "?";
}

Eigen::Matrix4d euler_to_matrix4_3dtk(const Eigen::Vector3d& translation, const Eigen::Vector3d& theta_deg) {
  const double to_rad = M_PI / 180.0;
  const double sx = std::sin(theta_deg.x() * to_rad), cx = std::cos(theta_deg.x() * to_rad);
  const double sy = std::sin(theta_deg.y() * to_rad), cy = std::cos(theta_deg.y() * to_rad);
  const double sz = std::sin(theta_deg.z() * to_rad), cz = std::cos(theta_deg.z() * to_rad);
  const double m[16] = {cy * cz,  sx * sy * cz + cx * sz,  -cx * sy * cz + sx * sz, 0,
                        -cy * sz, -sx * sy * sz + cx * cz, cx * sy * sz + sx * cz,  0,
                        sy,       -sx * cy,                cx * cy,                 0,
                        translation.x(), translation.y(), translation.z(), 1};
  return from_column_major(m);
}

Eigen::Matrix4d from_column_major(const double* m) {
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out(r, c) = m[c * 4 + r];
  }
  return out;
}

Eigen::Matrix4d load_pose(const std::string& path, PoseFormat format, double scale_to_m) {
  const auto lines = numeric_lines(path);
  Eigen::Matrix4d pose;
  switch (format) {
    case PoseFormat::tdtk_pose: {
      if (lines.size() != 2 || lines[0].size() != 3 || lines[1].size() != 3) {
        throw InputError("wrong 3DTK .pose file " + path + ": expected two lines 'tx ty tz' and 'θx θy θz'");
      }
      pose = euler_to_matrix4_3dtk({lines[0][0], lines[0][1], lines[0][2]}, {lines[1][0], lines[1][1], lines[1][2]});
      break;
    }
    case PoseFormat::tdtk_frames: {
      if (lines.empty() || (lines.back().size() != 17 && lines.back().size() != 16)) {
        throw InputError("wrong 3DTK .frames file " + path + ": the last line must hold 16 matrix numbers and a flag");
      }
      pose = from_column_major(lines.back().data());
      break;
    }
    case PoseFormat::matrix4_row_major: {
      if (lines.size() != 4) throw InputError("wrong 4x4 matrix file " + path + ": expected 4 lines of 4 numbers");
      for (int r = 0; r < 4; ++r) {
        if (lines[r].size() != 4) throw InputError("wrong 4x4 matrix file " + path + ": expected 4 lines of 4 numbers");
        for (int c = 0; c < 4; ++c) pose(r, c) = lines[r][c];
      }
      break;
    }
  }
  check_matrix(path, pose);
  pose.topRightCorner<3, 1>() *= scale_to_m;
  return pose;
}

}  // namespace nnb::datasets
