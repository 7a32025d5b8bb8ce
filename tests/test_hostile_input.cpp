// Hostile input: extreme coordinates, headers that claim more points than their file can hold, and
// silently corrupt text. Each is refused with one InputError line, before any library or big allocation.
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/loaders.hpp"
#include "nnb/registry.hpp"

#include "cross_check.hpp"
#include "input_files.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

// The sanitizer build checks indices with libstdc++'s assertions too (the top CMakeLists.txt).
#if defined(__SANITIZE_ADDRESS__) && !defined(_GLIBCXX_ASSERTIONS)
#error "the sanitizer build lacks _GLIBCXX_ASSERTIONS"
#endif

namespace fs = std::filesystem;
using namespace nnb::datasets;
using nnb::Cloud;
using nnb::InputError;

using nnb::test::expect_input_error;
using nnb::test::TempDir;

namespace {

/// Runs f in a child limited to limit_mib of address space; true when it ended with an InputError.
template <class F>
bool refuses_within_memory(F&& f, std::size_t limit_mib) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const rlimit limit{limit_mib << 20, limit_mib << 20};
    ::setrlimit(RLIMIT_AS, &limit);
    int code = 3;
    try {
      f();
      code = 1;
    } catch (const InputError&) {
      code = 0;
    } catch (...) {
      code = 4;
    }
    ::_exit(code);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

std::string pcd_header(const std::string& data, unsigned long long points, const std::string& fields = "x y z",
                       const std::string& sizes = "4 4 4", const std::string& types = "F F F") {
  return "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\nWIDTH " +
         std::to_string(points) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points) + "\nDATA " +
         data + "\n";
}

Cloud random_cloud(int n, double scale, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Cloud cloud(3, n);
  for (int i = 0; i < n; ++i) cloud.col(i) << u(rng) * scale, u(rng) * scale, u(rng) * scale;
  return cloud;
}

std::string xyz_text(const Cloud& cloud) {
  std::ostringstream text;
  text.precision(17);
  for (Eigen::Index i = 0; i < cloud.cols(); ++i) text << cloud(0, i) << ' ' << cloud(1, i) << ' ' << cloud(2, i) << '\n';
  return text.str();
}

// ---------------------------------------------------------------- coordinate contract

TEST(CoordinateRange, FileBeyondTheBoundIsRefusedByTheCatalog) {
  const TempDir dir;
  const auto path = dir.file("far.xyz", xyz_text(random_cloud(200, 1e200, 1)));
  expect_input_error([&] { resolve_cloud(path, Role::model, DataOptions{}); }, {"far.xyz", "point 0", "1e+15"});
  const auto mild = dir.file("mild.xyz", "1 2 3\n4 5 6\n-7 8 2e15\n");
  expect_input_error([&] { resolve_cloud(mild, Role::query, DataOptions{}); }, {"mild.xyz", "point 2", "2000000000000000", "1e+15"});
}

TEST(CoordinateRange, EveryAdapterRefusesModelAndQueriesBeyondTheBound) {
  const Cloud far = random_cloud(50, 1e20, 2);
  const Cloud near = random_cloud(50, 1.0, 3);
  for (const auto& name : nnb::adapter_names()) {
    auto index = nnb::make_adapter(name, {});
    expect_input_error([&] { index->build(far); }, {name, "model cloud", "point 0"});
    index->build(near);
    nnb::Neighbours out;
    expect_input_error([&] { index->knn(far, 1, out); }, {name, "query cloud", "point 0"});
  }
}

// The adapters the coordinate checks are tried on: brute force, and ours when it is built in (NNB_WITH_OURS).
std::vector<std::string> brute_force_and_ours() {
  std::vector<std::string> names{"brute_force"};
  if (nnb::adapter_built_in("ours_kdtree")) names.emplace_back("ours_kdtree");
  return names;
}

TEST(CoordinateRange, ABadPointAmongGoodOnesIsNamed) {
  // One bad coordinate anywhere in a cloud of good ones: refused, naming that point.
  const Cloud good = random_cloud(1000, 1.0, 8);
  for (const std::string& name : brute_force_and_ours()) {
    auto index = nnb::make_adapter(name, {});
    Cloud model = good;
    model(0, 3) = -std::numeric_limits<double>::infinity();
    expect_input_error([&] { index->build(model); }, {name, "model point 3", "non-finite"});
    model(0, 3) = 0.5;
    model(2, 998) = -2e15;
    expect_input_error([&] { index->build(model); }, {name, "model cloud", "point 998", "1e+15"});
    index->build(good);
    nnb::Neighbours out;
    Cloud queries = good;
    queries(1, 517) = std::numeric_limits<double>::quiet_NaN();
    expect_input_error([&] { index->ranged(queries, 1, 0.1, out); }, {name, "query point 517", "non-finite"});
    queries(1, 517) = 0.25;
    queries(0, 999) = 1.5e15;
    expect_input_error([&] { index->knn(queries, 1, out); }, {name, "query cloud", "point 999", "1e+15"});
    queries(0, 999) = nnb::kMaxAbsCoordinate_m;  // at the bound: accepted
    EXPECT_NO_THROW(index->knn(queries, 1, out)) << name;
  }
}

// On threads each checks its own share of the queries, yet the message names the point one thread names:
// the first non-finite one, else the first out of range, in whichever share they lie.
TEST(CoordinateRange, ABadQueryOnThreadsIsNamedAsOnOne) {
  const Cloud good = random_cloud(2000, 1.0, 9);
  for (const std::string& name : brute_force_and_ours()) {
    auto index = nnb::make_adapter(name, {});
    index->build(good);
    nnb::Neighbours out;
    for (const int threads : {2, 3}) {
      index->set_threads(threads);
      const std::string where = name + " on " + std::to_string(threads) + " threads";
      Cloud queries = good;
      queries(2, 1700) = 3e15;
      expect_input_error([&] { index->knn(queries, 1, out); }, {name, "query cloud", "point 1700", "1e+15"});
      queries(0, 200) = -2e15;
      expect_input_error([&] { index->ranged(queries, 1, 0.1, out); }, {name, "query cloud", "point 200", "1e+15"});
      queries(1, 1900) = std::numeric_limits<double>::infinity();
      expect_input_error([&] { index->knn(queries, 1, out); }, {name, "query point 1900", "non-finite"});
      EXPECT_NO_THROW(index->knn(good, 1, out)) << where;
      EXPECT_EQ(out.n_queries(), 2000u) << where;
    }
  }
}

// Every exact adapter answers k-NN (k = 3), ranged search with each of its strategies and radius search at
// dist_m exactly as brute force does on (model, queries).
void expect_every_exact_adapter_as_brute_force(const Cloud& model, const Cloud& queries, double dist_m) {
  auto reference = nnb::make_adapter("brute_force", {});
  reference->build(model);
  nnb::Neighbours expected_knn, expected_ranged, expected_radius;
  reference->knn(queries, 3, expected_knn);
  reference->ranged(queries, 3, dist_m, expected_ranged);
  reference->radius(queries, dist_m, expected_radius);
  const auto same = [&](const nnb::Neighbours& expected, const nnb::Neighbours& got) {
    return nnb::testing::compare_with_reference(model, queries, expected, got, false);
  };
  for (const auto& name : nnb::adapter_names()) {
    auto index = nnb::make_adapter(name, {});
    if (!index->info().exact) continue;
    index->build(model);
    nnb::Neighbours got;
    const std::string where = name + " at " + std::to_string(dist_m) + " m";
    index->knn(queries, 3, got);
    EXPECT_EQ(same(expected_knn, got), "") << where << " knn";
    for (const nnb::Strategy s : index->info().strategies(nnb::SearchKind::ranged)) {
      index->ranged(queries, 3, dist_m, got, s);
      EXPECT_EQ(same(expected_ranged, got), "") << where << " ranged " << nnb::to_string(s);
    }
    if (index->info().radius != nnb::Strategy::unsupported) {
      index->radius(queries, dist_m, got);
      EXPECT_EQ(same(expected_radius, got), "") << where << " radius";
    }
  }
}

TEST(CoordinateRange, EveryAdapterIsExactAtTheBound) {
  // The contract is only worth its name if every library answers exactly up to it.
  const double bound = nnb::kMaxAbsCoordinate_m;
  Cloud model = random_cloud(200, bound, 4);
  model.col(0) << bound, -bound, bound;
  expect_every_exact_adapter_as_brute_force(model, random_cloud(20, bound, 5), 0.5 * bound);
}

TEST(CoordinateRange, EveryAdapterIsExactFarFromATinyModel) {
  // A model 0.1 mm across and queries 1e9 and 1e15 m away: grids and bins sized by the model put such a
  // query billions of cells off (an integer cell index overflows), and float distances lose the model.
  const Cloud model = random_cloud(200, 1e-4, 6);
  Cloud queries = random_cloud(12, 1e-4, 7);
  queries.rightCols(8) << 1e9, -1e9, 1e9, 0, 1e15, -1e15, 0, 1e15,  //
      0, 1e9, -1e9, 1e9, 0, 1e15, -1e15, 3e-5,                      //
      0, 0, 1e9, -1e9, 0, 0, 1e15, -1e15;
  for (const double dist_m : {1e-5, 2e9, 1e16}) expect_every_exact_adapter_as_brute_force(model, queries, dist_m);
}

// ---------------------------------------------------------------- counts claimed by headers

TEST(ClaimedCounts, AsciiPcdClaimingFiftyMillionPointsIsRefusedWithoutAllocating) {
  const TempDir dir;
  const auto path = dir.file("huge.pcd", pcd_header("ascii", 50000000) + "1 2 3\n");
  expect_input_error([&] { load_points(path); }, {"huge.pcd", "50000000", "bytes"});
  EXPECT_TRUE(refuses_within_memory([&] { load_points(path); }, 256));
}

TEST(ClaimedCounts, AsciiPcdClaimingTwoBillionPointsIsRefused) {
  const TempDir dir;
  const auto path = dir.file("huge.pcd", pcd_header("ascii", 2000000000) + "1 2 3\n");
  expect_input_error([&] { load_points(path); }, {"huge.pcd", "2000000000"});
}

TEST(ClaimedCounts, CompressedPcdClaimingMorePointsThanLzfCanHoldIsRefused) {
  const TempDir dir;
  const std::uint32_t sizes[2] = {4, 50000000u * 12u};
  std::string block(8, '\0');
  std::memcpy(block.data(), sizes, 8);
  block += std::string("\x02\x00\x00\x00", 4);
  const auto path = dir.file("bomb.pcd", pcd_header("binary_compressed", 50000000) + block);
  expect_input_error([&] { load_points(path); }, {"bomb.pcd", "50000000"});
  EXPECT_TRUE(refuses_within_memory([&] { load_points(path); }, 256));
}

TEST(ClaimedCounts, PcdWidthTimesHeightMayNotWrapAround) {
  const TempDir dir;
  const auto path = dir.file("wrap.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\n"
                                         "HEIGHT 4294967296\nDATA binary\n");
  expect_input_error([&] { load_points(path); }, {"wrap.pcd", "WIDTH"});
}

TEST(ClaimedCounts, PlyVertexCountBeyondTheFileIsRefusedWithoutAllocating) {
  const TempDir dir;
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty double x\n"
                             "property double y\nproperty double z\nend_header\n";
  const auto path = dir.file("huge.ply", header + std::string(header.size() * 4, '\0'));
  expect_input_error([&] { load_points(path); }, {"huge.ply", "100000000", "24 bytes"});
  EXPECT_TRUE(refuses_within_memory([&] { load_points(path); }, 256));
}

TEST(ClaimedCounts, PlyElementWithoutPropertiesDoesNotHang) {
  const TempDir dir;
  const auto path = dir.file("empty.ply", "ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\n"
                                          "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                                          "end_header\n" + std::string("\0\0\x80\x3f\0\0\x80\x3f\0\0\x80\x3f", 12));
  EXPECT_EQ(load_points(path).points.col(0), Eigen::Vector3d(1, 1, 1));
}

TEST(ClaimedCounts, PlyCountMustBeAWholeNumber) {
  const TempDir dir;
  const auto path = dir.file("count.ply", "ply\nformat ascii 1.0\nelement vertex 1e3\nproperty float x\n"
                                          "property float y\nproperty float z\nend_header\n1 2 3\n");
  expect_input_error([&] { load_points(path); }, {"count.ply", "element vertex 1e3"});
}

// ---------------------------------------------------------------- silent corruption

TEST(SilentCorruption, AsciiPcdWordIsRefusedWithItsLine) {
  const TempDir dir;
  const auto path = dir.file("word.pcd", pcd_header("ascii", 2) + "1 2 3\nabc 5 6\n");
  expect_input_error([&] { load_points(path); }, {"word.pcd", "line 11", "abc"});
}

TEST(SilentCorruption, AsciiPcdDecimalCommaIsRefused) {
  const TempDir dir;
  const auto path = dir.file("comma.pcd", pcd_header("ascii", 1) + "1,5 2 3\n");
  expect_input_error([&] { load_points(path); }, {"comma.pcd", "line 10", "1,5"});
}

TEST(SilentCorruption, AsciiPcdShortLineIsRefused) {
  const TempDir dir;
  const auto path = dir.file("short.pcd", pcd_header("ascii", 2) + "1 2 3\n4 5        \n");
  expect_input_error([&] { load_points(path); }, {"short.pcd", "line 11", "field z of point 1"});
}

TEST(SilentCorruption, AsciiPcdLoadsAsPclWould) {
  const TempDir dir;
  const auto path = dir.file("ok.pcd", pcd_header("ascii", 2, "x y z i", "4 8 2 1", "F F I U") +
                                           "0.1 0.1 -7 255\n+1e3 2.5 32767 0\n");
  const auto loaded = load_points(path);
  ASSERT_EQ(loaded.points.cols(), 2);
  EXPECT_EQ(loaded.points.col(0), Eigen::Vector3d(double(0.1f), 0.1, -7));
  EXPECT_EQ(loaded.points.col(1), Eigen::Vector3d(1000, 2.5, 32767));
  expect_input_error([&] { load_points(dir.file("range.pcd", pcd_header("ascii", 1, "x y z", "4 4 1", "F F I") + "1 2 300\n")); },
                     {"range.pcd", "line 10", "field z"});
}

TEST(SilentCorruption, HalfGarbage3dFileIsRefusedWithItsLine) {
  const TempDir dir;
  const auto path = dir.file("half.3d", "1 2 3\n4 5 6\n#@!garbage\n7 8 9\n");
  expect_input_error([&] { load_points(path); }, {"half.3d", "line 3", "garbage"});
  const auto header_late = dir.file("late.3d", "1 2 3\n360 x 225\n");
  expect_input_error([&] { load_points(header_late); }, {"late.3d", "line 2"});
}

TEST(SilentCorruption, BinRecordSizeIsTwelveBytes) {
  // FORMATS.md: .bin holds x y z float32 triplets; a KITTI x y z intensity file whose size is not a
  // multiple of 12 is refused, not read as shifted floats.
  const TempDir dir;
  std::string kitti;
  for (int i = 0; i < 5; ++i) {
    const float record[4] = {1.0f + i, 2.0f, 3.0f, 0.5f};
    kitti.append(reinterpret_cast<const char*>(record), 16);
  }
  expect_input_error([&] { load_points(dir.file("kitti.bin", kitti)); }, {"kitti.bin", "80 bytes", "multiple of 12"});
}

}  // namespace
