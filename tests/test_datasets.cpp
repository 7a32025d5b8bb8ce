// Loaders, poses, checksums and the catalog, on the shared real scans (from default_data_dir()) and on
// bad fixture files written to a temporary directory at test time.
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/checksum.hpp"
#include "nnb/datasets/loaders.hpp"
#include "nnb/datasets/poses.hpp"
#include "nnb/datasets/synthetic.hpp"
#include "input_files.hpp"
#include "real_data.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

#include <unistd.h>

namespace fs = std::filesystem;
using namespace nnb::datasets;
using nnb::InputError;

using nnb::test::expect_input_error;
using nnb::test::TempDir;

namespace {

std::string real_file(const std::string& folder, const std::string& file) {
  return (fs::path(default_data_dir()) / folder / file).string();
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string float_bytes(std::initializer_list<float> values, bool big_endian = false) {
  std::string out;
  for (float v : values) {
    char b[4];
    std::memcpy(b, &v, 4);
    if (big_endian) { std::swap(b[0], b[3]); std::swap(b[1], b[2]); }
    out.append(b, 4);
  }
  return out;
}

// ---------------------------------------------------------------- every real file, every loader

struct RealCase {
  const char* folder;
  const char* file;
  std::size_t n_read;
  std::size_t n_non_finite;
  std::size_t n_zero;
};

void PrintTo(const RealCase& c, std::ostream* os) { *os << c.file; }

class RealFile : public ::testing::TestWithParam<RealCase> {};

TEST_P(RealFile, ReadsTheManifestCounts) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const RealCase& c = GetParam();
  const LoadedPoints loaded = load_points(real_file(c.folder, c.file));
  EXPECT_EQ(loaded.n_read, c.n_read);
  EXPECT_EQ(loaded.n_non_finite, c.n_non_finite);
  EXPECT_EQ(loaded.n_zero, c.n_zero);
  EXPECT_EQ(static_cast<std::size_t>(loaded.points.cols()), c.n_read - c.n_non_finite - c.n_zero);
  EXPECT_EQ(nnb::first_non_finite(loaded.points), -1);
  EXPECT_EQ(loaded.n_skipped_lines, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Shared, RealFile,
    ::testing::Values(RealCase{"office-sick-3dtk", "scan000.3d", 81360, 0, 0},
                      RealCase{"office-sick-3dtk", "scan001.3d", 81360, 0, 0},
                      RealCase{"office-sick-3dtk", "scan002.3d", 81360, 0, 0},
                      RealCase{"office-kinect-pcl", "capture0001.pcd", 307200, 307200 - 249647, 0},
                      RealCase{"office-kinect-pcl", "capture0002.pcd", 307200, 307200 - 249931, 0},
                      RealCase{"office-kinect-pcl", "capture0003.pcd", 307200, 307200 - 248494, 0},
                      RealCase{"office-kinect-pcl", "capture0004.pcd", 307200, 307200 - 244573, 0},
                      RealCase{"office-kinect-pcl", "capture0005.pcd", 307200, 307200 - 244977, 0},
                      RealCase{"velodyne-hdl32-fastgicp", "251370668.pcd", 69088, 0, 5032},
                      RealCase{"velodyne-hdl32-fastgicp", "251371071.pcd", 69792, 0, 5107},
                      RealCase{"kitti00-hdl64-gtsampoints", "000000.bin", 124668, 0, 0},
                      RealCase{"kitti00-hdl64-gtsampoints", "000001.bin", 124605, 0, 0},
                      RealCase{"bunny-stanford", "bun000.ply", 40256, 0, 0},
                      RealCase{"bunny-stanford", "bun045.ply", 40097, 0, 0}),
    [](const auto& info) {
      std::string name = info.param.file;
      for (char& c : name) c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
      return name;
    });

TEST(RealFileValues, SickIsConvertedFromCentimetres) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  // scan000.3d begins with "10.1 0 0" and "10.0996 -0.0662149 0.0581712" (cm).
  const auto loaded = load_points(real_file("office-sick-3dtk", "scan000.3d"));
  EXPECT_DOUBLE_EQ(loaded.points(0, 0), 10.1 * 0.01);
  EXPECT_EQ(loaded.points(1, 0), 0.0);
  EXPECT_DOUBLE_EQ(loaded.points(0, 1), 10.0996 * 0.01);
  EXPECT_DOUBLE_EQ(loaded.points(1, 1), -0.0662149 * 0.01);
  EXPECT_DOUBLE_EQ(loaded.points(2, 1), 0.0581712 * 0.01);
  const auto in_cm = load_points(real_file("office-sick-3dtk", "scan000.3d"), PointFormat::tdtk_3d, 1.0);
  EXPECT_DOUBLE_EQ(in_cm.points(0, 1), 10.0996);
}

TEST(RealFileValues, BunnyPlyMatchesItsText) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  // The first vertex line after end_header, parsed independently here.
  const std::string text = slurp(real_file("bunny-stanford", "bun000.ply"));
  const std::size_t body = text.find("end_header\n") + std::strlen("end_header\n");
  std::istringstream first(text.substr(body, text.find('\n', body) - body));
  double x, y, z;
  first >> x >> y >> z;
  const auto loaded = load_points(real_file("bunny-stanford", "bun000.ply"));
  EXPECT_EQ(loaded.points(0, 0), x);
  EXPECT_EQ(loaded.points(1, 0), y);
  EXPECT_EQ(loaded.points(2, 0), z);
  EXPECT_LT(loaded.points.cwiseAbs().maxCoeff(), 0.3);  // the bunny is about 0.15 m across
}

TEST(RealFileValues, KittiBinIsRawFloats) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const std::string bytes = slurp(real_file("kitti00-hdl64-gtsampoints", "000000.bin"));
  float last[3];
  std::memcpy(last, bytes.data() + bytes.size() - 12, 12);
  const auto loaded = load_points(real_file("kitti00-hdl64-gtsampoints", "000000.bin"));
  for (int a = 0; a < 3; ++a) EXPECT_EQ(loaded.points(a, loaded.points.cols() - 1), static_cast<double>(last[a]));
}

TEST(RealFileValues, FormatOverrideWins) {
  const TempDir dir;
  const std::string path = dir.file("points.dat", "1 2 3\n4 5 6\n");
  expect_input_error([&] { load_points(path); }, {"points.dat", "extension"});
  EXPECT_EQ(load_points(path, PointFormat::xyz_text).n_read, 2u);
  EXPECT_EQ(load_points(path, parse_point_format("3d")).points(0, 0), 0.01);
}

// ---------------------------------------------------------------- poses

TEST(Poses, SickFramesLastLineMatchesFormatsMd) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  Eigen::Matrix4d expected;
  expected << 0.999913, 0.00421739, -0.0124799, -3.6331,  //
      -0.00438033, 0.999905, -0.0130579, -9.08315,        //
      0.0124237, 0.0131114, 0.999837, 156.796,            //
      0, 0, 0, 1;
  const Eigen::Matrix4d in_cm = load_pose(real_file("office-sick-3dtk", "scan001.frames"), PoseFormat::tdtk_frames);
  EXPECT_EQ(in_cm, expected);
  const Eigen::Matrix4d in_m = load_pose(real_file("office-sick-3dtk", "scan001.frames"), PoseFormat::tdtk_frames, 0.01);
  EXPECT_EQ(Eigen::Matrix3d(in_m.topLeftCorner<3, 3>()), Eigen::Matrix3d(expected.topLeftCorner<3, 3>()));
  EXPECT_DOUBLE_EQ(in_m(0, 3), -3.6331 * 0.01);
  EXPECT_DOUBLE_EQ(in_m(2, 3), 156.796 * 0.01);
  EXPECT_EQ(load_pose(real_file("office-sick-3dtk", "scan000.frames"), PoseFormat::tdtk_frames), Eigen::Matrix4d::Identity());
}

TEST(Poses, EulerToMatrix4IsRxRyRz) {
  const Eigen::Vector3d theta_deg(1.35694, -0.852409, -0.56224);
  const Eigen::Vector3d theta = theta_deg * M_PI / 180.0;
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(theta.x(), Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(theta.y(), Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(theta.z(), Eigen::Vector3d::UnitZ())).toRotationMatrix();
  const Eigen::Matrix4d m = euler_to_matrix4_3dtk(Eigen::Vector3d(1, 2, 3), theta_deg);
  EXPECT_LT((m.topLeftCorner<3, 3>() - expected).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(Eigen::Vector3d(m.topRightCorner<3, 1>()), Eigen::Vector3d(1, 2, 3));
  // +90 deg about x takes y to z.
  const Eigen::Matrix4d rx = euler_to_matrix4_3dtk(Eigen::Vector3d::Zero(), Eigen::Vector3d(90, 0, 0));
  EXPECT_LT((rx.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
}

TEST(Poses, SickPoseFileIsCloseToTheFramesResult) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const std::string path = real_file("office-sick-3dtk", "scan001.pose");
  const Eigen::Matrix4d pose = load_pose(path, PoseFormat::tdtk_pose, 0.01);
  EXPECT_DOUBLE_EQ(pose(0, 3), -3.10605 * 0.01);
  EXPECT_DOUBLE_EQ(pose(1, 3), -7.50803 * 0.01);
  EXPECT_DOUBLE_EQ(pose(2, 3), 156.917 * 0.01);
  const Eigen::Matrix4d frames = load_pose(real_file("office-sick-3dtk", "scan001.frames"), PoseFormat::tdtk_frames, 0.01);
  const Eigen::AngleAxisd between(Eigen::Matrix3d(pose.topLeftCorner<3, 3>().transpose() * frames.topLeftCorner<3, 3>()));
  EXPECT_LT(between.angle() * 180.0 / M_PI, 2.5);  // odometry is within a few degrees of slam6D
  EXPECT_LT((pose.topRightCorner<3, 1>() - frames.topRightCorner<3, 1>()).norm(), 0.05);
  EXPECT_EQ(load_pose(real_file("office-sick-3dtk", "scan000.pose"), PoseFormat::tdtk_pose), Eigen::Matrix4d::Identity());
}

TEST(Poses, RowMajorMatrixFiles) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const Eigen::Matrix4d velodyne = load_pose(real_file("velodyne-hdl32-fastgicp", "relative.txt"), PoseFormat::matrix4_row_major);
  EXPECT_EQ(velodyne(0, 1), 0.0108432);
  EXPECT_EQ(velodyne(0, 3), 0.485657);
  EXPECT_EQ(velodyne(2, 3), -0.0131581);
  const Eigen::Matrix4d kitti =
      load_pose(real_file("kitti00-hdl64-gtsampoints", "T_velo0_velo1.derived.txt"), parse_pose_format("4x4-row-major-text"));
  EXPECT_EQ(kitti(0, 3), 0.858767647);
  const Eigen::Matrix4d bunny = load_pose(real_file("bunny-stanford", "T_bun000_bun045.derived.txt"), PoseFormat::matrix4_row_major);
  EXPECT_EQ(bunny(2, 0), -0.563140830);
}

TEST(Poses, BadPoseFiles) {
  const TempDir dir;
  expect_input_error([&] { load_pose(dir.path() + "/none.txt", PoseFormat::matrix4_row_major); }, {"missing", "none.txt"});
  const auto three = dir.file("three.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  expect_input_error([&] { load_pose(three, PoseFormat::matrix4_row_major); }, {"three.txt"});
  const auto word = dir.file("word.txt", "1 0 0 0\n0 1 x 0\n0 0 1 0\n0 0 0 1\n");
  expect_input_error([&] { load_pose(word, PoseFormat::matrix4_row_major); }, {"malformed number", "word.txt", "line 2"});
  const auto row = dir.file("row.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  expect_input_error([&] { load_pose(row, PoseFormat::matrix4_row_major); }, {"last row", "row.txt"});
  const auto frames = dir.file("short.frames", "1 0 0 0 0 1 0 0 0 0 1 0 0 0\n");
  expect_input_error([&] { load_pose(frames, PoseFormat::tdtk_frames); }, {"short.frames"});
  expect_input_error([&] { parse_pose_format("quaternion"); }, {"quaternion"});
}

// ---------------------------------------------------------------- sha256

TEST(Sha256, KnownVectorsAndARealFile) {
  const TempDir dir;
  EXPECT_EQ(sha256_file(dir.file("abc", "abc")), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_file(dir.file("empty", "")), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  NNB_SKIP_WITHOUT_REAL_DATA();
  EXPECT_EQ(sha256_file(real_file("office-sick-3dtk", "scan000.3d")),
            "0814652e3c1cd4ec2ad5a39ab282bdd278b9a0df0ac3866d0ab651a7b5b07652");
  expect_input_error([&] { sha256_file(dir.path() + "/none"); }, {"none"});
}

// ---------------------------------------------------------------- bad input

TEST(BadInput, MissingFileInEveryFormat) {
  const TempDir dir;
  for (const char* name : {"a.3d", "a.pcd", "a.ply", "a.bin", "a.xyz"}) {
    expect_input_error([&] { load_points(dir.path() + "/" + name); }, {"missing file", name});
  }
}

TEST(BadInput, EmptyFileInEveryFormat) {
  const TempDir dir;
  for (const char* name : {"a.3d", "a.pcd", "a.ply", "a.bin", "a.xyz"}) {
    const auto path = dir.file(name, "");
    expect_input_error([&] { load_points(path); }, {"empty file", name});
  }
}

TEST(BadInput, TruncatedBinaryPcd) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const TempDir dir;
  const std::string bytes = slurp(real_file("velodyne-hdl32-fastgicp", "251370668.pcd"));
  const auto half = dir.file("half.pcd", bytes.substr(0, bytes.size() / 2));
  expect_input_error([&] { load_points(half); }, {"half.pcd"});
  const auto one_short = dir.file("short.pcd", bytes.substr(0, bytes.size() - 1));
  expect_input_error([&] { load_points(one_short); }, {"short.pcd"});
}

TEST(BadInput, TruncatedCompressedPcd) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const TempDir dir;
  const std::string bytes = slurp(real_file("office-kinect-pcl", "capture0001.pcd"));
  const auto half = dir.file("half.pcd", bytes.substr(0, bytes.size() / 2));
  expect_input_error([&] { load_points(half); }, {"half.pcd"});
  const auto header_only = dir.file("header.pcd", bytes.substr(0, bytes.find("DATA binary_compressed\n") + 23));
  expect_input_error([&] { load_points(header_only); }, {"header.pcd"});
}

TEST(BadInput, CorruptCompressedPcdDoesNotCrash) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  // Same size, scrambled LZF bytes: PCL may decode garbage or refuse, but never crash.
  const TempDir dir;
  std::string bytes = slurp(real_file("office-kinect-pcl", "capture0001.pcd"));
  for (std::size_t i = bytes.size() / 3; i < bytes.size() / 3 + 64; ++i) bytes[i] = static_cast<char>(0xff);
  const auto path = dir.file("scrambled.pcd", bytes);
  try {
    const auto loaded = load_points(path);
    EXPECT_EQ(loaded.n_read, 307200u);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scrambled.pcd"), std::string::npos) << e.what();
  }
}

TEST(BadInput, ShortAsciiPcd) {
  const TempDir dir;
  const auto path = dir.file("short.pcd",
                             "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n"
                             "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n");
  expect_input_error([&] { load_points(path); }, {"short.pcd"});
}

TEST(BadInput, WrongPcdHeader) {
  const TempDir dir;
  const auto garbage = dir.file("garbage.pcd", "this is not a point cloud\n1 2 3\n");
  expect_input_error([&] { load_points(garbage); }, {"garbage.pcd"});
  const auto no_xyz = dir.file("rgb.pcd",
                               "VERSION 0.7\nFIELDS r g b\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
                               "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n");
  expect_input_error([&] { load_points(no_xyz); }, {"rgb.pcd", "x, y and z"});
  const auto lying = dir.file("lying.pcd",
                              "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
                              "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 5\nDATA binary\n" + float_bytes({1, 2, 3, 4, 5, 6}));
  expect_input_error([&] { load_points(lying); }, {"lying.pcd", "POINTS"});
  const auto binary = dir.file("binary.pcd",
                               "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
                               "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA binary\n" + float_bytes({1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(load_points(binary).points.col(1), Eigen::Vector3d(4, 5, 6));
}

TEST(BadInput, AsciiPcdWithNanAndZero) {
  const TempDir dir;
  const auto path = dir.file("ascii.pcd",
                             "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\n"
                             "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n1 2 3\nnan nan nan\n0 0 0\n-4.5 5 6\n");
  const auto loaded = load_points(path);
  EXPECT_EQ(loaded.n_read, 4u);
  EXPECT_EQ(loaded.n_non_finite, 1u);
  EXPECT_EQ(loaded.n_zero, 1u);
  ASSERT_EQ(loaded.points.cols(), 2);
  EXPECT_EQ(loaded.points.col(1), Eigen::Vector3d(-4.5, 5, 6));
}

std::string ply_header(const char* format, int n_vertices) {
  return std::string("ply\nformat ") + format + " 1.0\ncomment test\nelement vertex " + std::to_string(n_vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar flag\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
}

TEST(BadInput, BinaryPlyBothEndiansAndTruncated) {
  const TempDir dir;
  for (const bool big : {false, true}) {
    std::string body;
    for (float base : {1.0f, 4.0f, 7.0f}) body += float_bytes({base, base + 1, base + 2}, big) + std::string(1, '\x05');
    const std::string face = std::string(1, '\x03') + std::string(12, '\0');
    const std::string bytes = ply_header(big ? "binary_big_endian" : "binary_little_endian", 3) + body + face;
    const auto whole = dir.file(big ? "be.ply" : "le.ply", bytes);
    const auto loaded = load_points(whole);
    ASSERT_EQ(loaded.points.cols(), 3);
    EXPECT_EQ(loaded.points.col(2), Eigen::Vector3d(7, 8, 9));
    const auto cut = dir.file("cut.ply", bytes.substr(0, bytes.size() - face.size() - 7));
    expect_input_error([&] { load_points(cut); }, {"truncated", "cut.ply"});
  }
}

TEST(BadInput, AsciiPlyTruncatedMalformedAndWrongHeader) {
  const TempDir dir;
  const std::string header = ply_header("ascii", 3);
  EXPECT_EQ(load_points(dir.file("ok.ply", header + "1 2 3 0\n4 5 6 0\n7 8 9 0\n3 0 1 2\n")).points.cols(), 3);
  expect_input_error([&] { load_points(dir.file("cut.ply", header + "1 2 3 0\n4 5 6 0\n")); }, {"truncated", "cut.ply"});
  expect_input_error([&] { load_points(dir.file("bad.ply", header + "1 2 3 0\n4 5x 6 0\n7 8 9 0\n")); },
                     {"malformed number", "bad.ply"});
  expect_input_error([&] { load_points(dir.file("magic.ply", "plx\n" + header.substr(4))); }, {"wrong PLY header", "magic.ply"});
  expect_input_error([&] { load_points(dir.file("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n")); },
                     {"end_header", "noend.ply"});
  expect_input_error(
      [&] { load_points(dir.file("nox.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nend_header\n1\n")); },
      {"x, y and z", "nox.ply"});
  expect_input_error([&] { load_points(dir.file("huge.ply", ply_header("binary_little_endian", 2000000000))); },
                     {"truncated", "huge.ply"});
}

TEST(BadInput, BinNotAMultipleOf12) {
  const TempDir dir;
  const auto path = dir.file("odd.bin", float_bytes({1, 2, 3, 4}));
  expect_input_error([&] { load_points(path); }, {"odd.bin", "16 bytes", "multiple of 12"});
}

TEST(BadInput, NanAndInfAreDroppedAndCounted) {
  const TempDir dir;
  const auto text = dir.file("mixed.xyz", "# comment\n1 2 3\nnan 1 1\n1 inf 1\n\n0 0 0\n1 1 -inf\n4 5 6 7\n");
  const auto loaded = load_points(text);
  EXPECT_EQ(loaded.n_read, 6u);
  EXPECT_EQ(loaded.n_non_finite, 3u);
  EXPECT_EQ(loaded.n_zero, 1u);
  ASSERT_EQ(loaded.points.cols(), 2);
  EXPECT_EQ(loaded.points.col(1), Eigen::Vector3d(4, 5, 6));

  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const auto bin = load_points(dir.file("mixed.bin", float_bytes({1, 2, 3, nan, 0, 0, 0, 0, 0, -inf, 1, 1})));
  EXPECT_EQ(bin.n_read, 4u);
  EXPECT_EQ(bin.n_non_finite, 2u);
  EXPECT_EQ(bin.n_zero, 1u);
}

TEST(BadInput, OnlyInvalidPointsIsAnEmptyCloudError) {
  const TempDir dir;
  expect_input_error([&] { load_points(dir.file("nan.xyz", "nan nan nan\nnan 1 2\n")); }, {"no valid point", "nan.xyz", "2 non-finite"});
  expect_input_error([&] { load_points(dir.file("zero.3d", "0 0 0\n")); }, {"no valid point", "zero.3d"});
  expect_input_error([&] { load_points(dir.file("words.3d", "not a scan\n")); }, {"no valid point", "words.3d"});
}

TEST(BadInput, MalformedNumberInText) {
  const TempDir dir;
  expect_input_error([&] { load_points(dir.file("bad.xyz", "1 2 3\n1 2 three\n")); }, {"malformed number", "bad.xyz", "line 2"});
  expect_input_error([&] { load_points(dir.file("two.xyz", "1 2\n")); }, {"malformed number", "two.xyz", "line 1"});
}

TEST(BadInput, OldSickHeaderLineIsSkipped) {
  const TempDir dir;
  const auto loaded = load_points(dir.file("old.3d", "360 x 225\n100 200 -300\n1.5e2 0 0\n"));
  EXPECT_EQ(loaded.n_skipped_lines, 1u);
  ASSERT_EQ(loaded.points.cols(), 2);
  EXPECT_EQ(loaded.points.col(0), Eigen::Vector3d(1, 2, -3));
}

// ---------------------------------------------------------------- manifest and catalog

TEST(Catalog, ManifestListsEveryPair) {
  const auto pairs = real_pairs();
  std::vector<std::string> names;
  for (const auto& p : pairs) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"office-sick-3dtk", "office-kinect-pcl", "velodyne-hdl32-fastgicp",
                                             "kitti00-hdl64-gtsampoints", "bunny-stanford"}));
  const auto sick = require_pair("office-sick-3dtk");
  EXPECT_EQ(sick.scale_to_m, 0.01);
  ASSERT_TRUE(sick.reference && sick.initial);
  EXPECT_EQ(sick.reference->file, "scan001.frames");
  EXPECT_EQ(sick.initial->file, "scan001.pose");
  const auto kinect = require_pair("office-kinect-pcl");
  EXPECT_FALSE(kinect.reference);
  ASSERT_TRUE(kinect.estimate);
  EXPECT_EQ(load_pair_pose(kinect, PoseKind::initial, {}).value(), Eigen::Matrix4d::Identity());
  EXPECT_FALSE(load_pair_pose(kinect, PoseKind::reference, {}));
  // The one line here that reads a file: the rest checks the manifest alone, which needs no data.
  if (nnb::test::real_data_present() || nnb::test::real_data_required()) {
    EXPECT_NEAR(load_pair_pose(kinect, PoseKind::estimate, {}).value()(0, 3), -0.11094002, 0);
  }
}

TEST(Catalog, EveryRealFileMatchesItsChecksumAndCount) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  for (const auto& pair : real_pairs()) {
    for (const Role role : {Role::model, Role::query}) {
      const NamedCloud cloud = load_pair_scan(pair, role, {});
      EXPECT_EQ(cloud.n_read, (role == Role::model ? pair.model : pair.query).expected_points) << pair.name;
      EXPECT_EQ(cloud.sha256, (role == Role::model ? pair.model : pair.query).sha256) << pair.name;
    }
    for (const PoseKind kind : {PoseKind::reference, PoseKind::initial, PoseKind::estimate}) {
      EXPECT_NO_THROW(load_pair_pose(pair, kind, {})) << pair.name;
    }
  }
}

TEST(Catalog, QueryOfAPairIsMovedByItsReferencePose) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const NamedCloud model = resolve_cloud("bunny-stanford", Role::model, {});
  EXPECT_EQ(model.kind, "real_pair");
  EXPECT_EQ(model.points.cols(), 40256);
  EXPECT_EQ(model.pose, Eigen::Matrix4d::Identity());
  const NamedCloud query = resolve_cloud("bunny-stanford", Role::query, {});
  const auto raw = load_points(real_file("bunny-stanford", "bun045.ply"));
  const Eigen::Matrix4d pose = load_pose(real_file("bunny-stanford", "T_bun000_bun045.derived.txt"), PoseFormat::matrix4_row_major);
  EXPECT_EQ(query.pose, pose);
  ASSERT_EQ(query.points.cols(), 40097);
  const Eigen::Vector3d moved = pose.topLeftCorner<3, 3>() * raw.points.col(123) + pose.topRightCorner<3, 1>();
  EXPECT_LT((query.points.col(123) - moved).norm(), 1e-15);

  // SICK: the .frames reference, not the .pose initial guess, in metres.
  const NamedCloud sick = resolve_cloud("office-sick-3dtk", Role::query, {});
  EXPECT_DOUBLE_EQ(sick.pose(2, 3), 1.56796);
  // Kinect: no reference, identity initial guess; NaNs dropped.
  const NamedCloud kinect = resolve_cloud("office-kinect-pcl", Role::query, {});
  EXPECT_EQ(kinect.pose, Eigen::Matrix4d::Identity());
  EXPECT_EQ(kinect.points.cols(), 249931);
  EXPECT_EQ(kinect.n_dropped, 307200u - 249931u);
}

TEST(Catalog, SyntheticShapesAndFilePaths) {
  DataOptions options;
  options.synthetic_points = 1000;
  options.seed = 9;
  const NamedCloud shape = resolve_cloud("filled_cube", Role::model, options);
  EXPECT_EQ(shape.kind, "synthetic");
  EXPECT_EQ(shape.points, make_shape(Shape::filled_cube, 1000, 9));
  NNB_SKIP_WITHOUT_REAL_DATA();
  const std::string path = real_file("kitti00-hdl64-gtsampoints", "000001.bin");
  const NamedCloud file = resolve_cloud(path, Role::query, options);
  EXPECT_EQ(file.kind, "file");
  EXPECT_EQ(file.points.cols(), 124605);
  EXPECT_EQ(file.sha256, "c4b8358b37ff38988bc213fdc368879dcdd37d42b0d1a65c2d9cf2ae0367a14c");
}

TEST(Catalog, UnknownNameListsTheKnownOnes) {
  expect_input_error([] { resolve_cloud("hollow_sphre", Role::model, {}); },
                     {"unknown data set 'hollow_sphre'", "hollow_sphere", "bunny-stanford", "office-sick-3dtk"});
  expect_input_error([] { require_pair("nope"); }, {"nope", "kitti00-hdl64-gtsampoints"});
  expect_input_error([] { resolve_cloud("/no/such/scan.pcd", Role::model, {}); }, {"missing file", "/no/such/scan.pcd"});
}

TEST(Catalog, ChecksumMismatchNamesFileAndBothHashes) {
  NNB_SKIP_WITHOUT_REAL_DATA();
  const TempDir dir;
  std::string bytes = slurp(real_file("bunny-stanford", "bun000.ply"));
  bytes[bytes.size() / 2] ^= 0x01;
  const auto path = dir.file("bunny-stanford/bun000.ply", bytes);
  DataOptions options;
  options.data_dir = dir.path();
  expect_input_error([&] { resolve_cloud("bunny-stanford", Role::model, options); },
                     {"checksum mismatch", path, "7d48f9fdf917311de680d074edce8aff25a4b9bfd87be9301822dace811209fb",
                      sha256_file(path)});
  // The same through NNB_DATA_DIR; and a missing query file there is named too.
  ASSERT_EQ(::setenv("NNB_DATA_DIR", dir.path().c_str(), 1), 0);
  EXPECT_EQ(default_data_dir(), dir.path());
  expect_input_error([&] { resolve_cloud("bunny-stanford", Role::model, {}); }, {"checksum mismatch", path});
  expect_input_error([&] { resolve_cloud("bunny-stanford", Role::query, {}); }, {"missing file", "bun045.ply"});
  ::unsetenv("NNB_DATA_DIR");
  // With checks off the (flipped, still parseable or not) file is simply read or rejected by the parser.
  options.verify_checksums = false;
  try {
    resolve_cloud("bunny-stanford", Role::model, options);
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
}

TEST(Catalog, ManifestOverrideAndMalformedManifest) {
  const TempDir dir;
  const auto bad = dir.file("manifest.json", "{\"pairs\": [ {\"name\": 1} ]}");
  ASSERT_EQ(::setenv("NNB_MANIFEST", bad.c_str(), 1), 0);
  expect_input_error([] { real_pairs(); }, {"malformed data set manifest", "manifest.json"});
  ASSERT_EQ(::setenv("NNB_MANIFEST", (dir.path() + "/none.json").c_str(), 1), 0);
  expect_input_error([] { real_pairs(); }, {"none.json"});
  ::unsetenv("NNB_MANIFEST");
  EXPECT_EQ(real_pairs().size(), 5u);
}

}  // namespace
