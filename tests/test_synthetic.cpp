#include "nnb/datasets/synthetic.hpp"

#include <gtest/gtest.h>

#include <cstring>

using nnb::datasets::make_shape;
using nnb::datasets::Shape;

namespace {

// FNV-1a over the bytes of the cloud: a platform-independent fingerprint of the generated points.
std::uint64_t fingerprint(const nnb::Cloud& cloud) {
  std::uint64_t h = 1469598103934665603ULL;
  const auto* bytes = reinterpret_cast<const unsigned char*>(cloud.data());
  for (std::size_t i = 0; i < sizeof(double) * static_cast<std::size_t>(cloud.size()); ++i) {
    h = (h ^ bytes[i]) * 1099511628211ULL;
  }
  return h;
}

class SyntheticShape : public ::testing::TestWithParam<Shape> {};

TEST_P(SyntheticShape, HasTheRequestedCount) {
  EXPECT_EQ(make_shape(GetParam(), 1234, 7).cols(), 1234);
  EXPECT_EQ(make_shape(GetParam(), 0, 7).cols(), 0);
}

TEST_P(SyntheticShape, SameSeedSameBytesOtherSeedOtherBytes) {
  const auto a = make_shape(GetParam(), 5000, 42);
  const auto b = make_shape(GetParam(), 5000, 42);
  const auto c = make_shape(GetParam(), 5000, 43);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())));
  EXPECT_NE(fingerprint(a), fingerprint(c));
}

TEST_P(SyntheticShape, PointsLieOnOrInTheShape) {
  const Shape shape = GetParam();
  const auto cloud = make_shape(shape, 20000, 3);
  for (Eigen::Index i = 0; i < cloud.cols(); ++i) {
    const Eigen::Vector3d p = cloud.col(i);
    switch (shape) {
      case Shape::hollow_sphere: ASSERT_NEAR(p.norm(), 1.0, 1e-12) << i; break;
      case Shape::filled_sphere: ASSERT_LE(p.squaredNorm(), 1.0) << i; break;
      case Shape::filled_cube: ASSERT_LE(p.cwiseAbs().maxCoeff(), 1.0) << i; break;
      case Shape::hollow_cube:
        ASSERT_EQ(p.cwiseAbs().maxCoeff(), 1.0) << i;
        ASSERT_EQ((p.cwiseAbs().array() == 1.0).count() >= 1, true) << i;
        break;
    }
  }
  // Spread over the whole shape: every octant is populated, the mean is near the centre.
  EXPECT_LT(cloud.rowwise().mean().norm(), 0.03);
  if (shape == Shape::filled_sphere || shape == Shape::filled_cube) {
    // In the volume: some points deep inside (a hollow generator would have none).
    EXPECT_GT((cloud.colwise().norm().array() < 0.5).count(), 100);
  }
}

INSTANTIATE_TEST_SUITE_P(AllShapes, SyntheticShape,
                         ::testing::Values(Shape::hollow_sphere, Shape::filled_sphere, Shape::hollow_cube,
                                           Shape::filled_cube),
                         [](const auto& info) { return std::string(nnb::datasets::to_string(info.param)); });

// Golden fingerprints: if these change, the same seed no longer gives the same bytes as before
// (on another platform or compiler, or after an edit to the mapping), which breaks comparability.
TEST(Synthetic, GoldenBytesAreStable) {
  EXPECT_EQ(fingerprint(make_shape(Shape::hollow_sphere, 1000, 1)), 13715647361952303053ULL);
  EXPECT_EQ(fingerprint(make_shape(Shape::filled_sphere, 1000, 1)), 15910711421423480275ULL);
  EXPECT_EQ(fingerprint(make_shape(Shape::hollow_cube, 1000, 1)), 7997142660806618896ULL);
  EXPECT_EQ(fingerprint(make_shape(Shape::filled_cube, 1000, 1)), 15194631495569679177ULL);
}

TEST(Synthetic, NamesRoundTrip) {
  for (const auto& name : nnb::datasets::shape_names()) {
    ASSERT_TRUE(nnb::datasets::parse_shape(name).has_value());
    EXPECT_EQ(name, nnb::datasets::to_string(*nnb::datasets::parse_shape(name)));
  }
  EXPECT_FALSE(nnb::datasets::parse_shape("hollow_torus").has_value());
}

}  // namespace
