#pragma once
// Pose files of the real pairs: 3DTK .pose (cm, degrees), 3DTK .frames (column-major OpenGL matrices,
// last line = final pose) and 4x4 row-major text. All give T_target_source: p_target = R p_source + t.
#include <Eigen/Core>

#include <string>

namespace nnb::datasets {

enum class PoseFormat { tdtk_pose, tdtk_frames, matrix4_row_major };

/// The pose format of that name: "3dtk-pose", "3dtk-frames", "4x4-row-major-text".
PoseFormat parse_pose_format(const std::string& name);
/// The canonical name of a pose format, as written in manifest.json.
const char* to_string(PoseFormat format);

/// 3DTK's EulerToMatrix4: translation (unchanged units) and angles θx θy θz in degrees -> 4x4 matrix.
Eigen::Matrix4d euler_to_matrix4_3dtk(const Eigen::Vector3d& translation, const Eigen::Vector3d& theta_deg);
/// The matrix stored column-major in m[0..15] (OpenGL / 3DTK layout: m[12..14] = translation).
Eigen::Matrix4d from_column_major(const double* m);

/// Reads a pose file; the translation is multiplied by scale_to_m (0.01 for the 3DTK cm files).
/// Throws InputError naming the file for a missing file, a wrong count of numbers or a bad last row.
Eigen::Matrix4d load_pose(const std::string& path, PoseFormat format, double scale_to_m = 1.0);

}  // namespace nnb::datasets
