// Portable mapping from std::mt19937_64 words to points. Every step is exact or a single correctly
// rounded IEEE operation (sqrt, division), and this file is compiled with -ffp-contract=off so no
// compiler fuses a multiply-add: the bytes are the same on every platform and compiler.
//   coord(w)  = (w >> 11) * 2^-52 - 1          uniform on the 2^53-grid of [-1, 1), exact
//   filled cube:    (coord, coord, coord)
//   hollow cube:    face = (w >> 61) rejected while >= 6; axis = face / 2, sign = face odd ? +1 : -1;
//                   the two other axes are coord(w), coord(w) in axis order
//   filled sphere:  p = (coord, coord, coord), rejected while |p|^2 > 1
//   hollow sphere:  p as above, rejected while |p|^2 > 1 or |p|^2 < 2^-20; p / sqrt(|p|^2)
#include "nnb/datasets/synthetic.hpp"

#include <array>
#include <cmath>
#include <random>

namespace nnb::datasets {

const std::vector<std::string>& shape_names() {
  static const std::vector<std::string> names{"hollow_sphere", "filled_sphere", "hollow_cube", "filled_cube"};
  return names;
}

const char* to_string(Shape shape) {
  switch (shape) {
    case Shape::hollow_sphere: return "hollow_sphere";
    case Shape::filled_sphere: return "filled_sphere";
    case Shape::hollow_cube: return "hollow_cube";
    case Shape::filled_cube: return "filled_cube";
  }
  return "?";
}

std::optional<Shape> parse_shape(const std::string& name) {
  for (const Shape s : {Shape::hollow_sphere, Shape::filled_sphere, Shape::hollow_cube, Shape::filled_cube}) {
    if (name == to_string(s)) return s;
  }
  return std::nullopt;
}

namespace {

double coord(std::mt19937_64& rng) {
  constexpr double kTwoToMinus52 = 1.0 / 4503599627370496.0;
  return static_cast<double>(rng() >> 11) * kTwoToMinus52 - 1.0;
}

std::array<double, 3> in_ball(std::mt19937_64& rng, double min_sq_norm) {
  while (true) {
    const std::array<double, 3> p{coord(rng), coord(rng), coord(rng)};
    const double sq = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    if (sq <= 1.0 && sq >= min_sq_norm) return p;
  }
}

std::array<double, 3> on_cube(std::mt19937_64& rng) {
  std::uint64_t face = rng() >> 61;
  while (face >= 6) face = rng() >> 61;
  const int axis = static_cast<int>(face / 2);
  std::array<double, 3> p{};
  p[axis] = (face % 2 == 1) ? 1.0 : -1.0;
  for (int other = 0; other < 3; ++other) {
    if (other != axis) p[other] = coord(rng);
  }
  return p;
}

}  // namespace

Cloud make_shape(Shape shape, std::size_t n_points, std::uint64_t seed) {
  if (n_points > kMaxSyntheticPoints) {
    throw InputError("a synthetic set holds at most " + std::to_string(kMaxSyntheticPoints) + " points, not " +
                     std::to_string(n_points) + (n_points > (std::size_t(1) << 62) ? " (a negative count?)" : ""));
  }
  std::mt19937_64 rng(seed);
  Cloud cloud(3, static_cast<Eigen::Index>(n_points));
  for (Eigen::Index i = 0; i < cloud.cols(); ++i) {
    std::array<double, 3> p{};
    switch (shape) {
      case Shape::filled_cube: p = {coord(rng), coord(rng), coord(rng)}; break;
      case Shape::hollow_cube: p = on_cube(rng); break;
      case Shape::filled_sphere: p = in_ball(rng, 0.0); break;
      case Shape::hollow_sphere: {
        p = in_ball(rng, 1.0 / 1048576.0);
        const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        p = {p[0] / norm, p[1] / norm, p[2] / norm};
        break;
      }
    }
    cloud.col(i) << p[0], p[1], p[2];
  }
  return cloud;
}

}  // namespace nnb::datasets
