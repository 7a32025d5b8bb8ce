#pragma once
// The paper's synthetic sets: hollow and filled sphere (radius 1 m) and cube (side 2 m), centred at
// the origin. Bit-identical on every platform for a given seed: the generator is std::mt19937_64
// (its sequence is fixed by the C++ standard) and the mapping to points uses only exact or correctly
// rounded IEEE operations (no standard distributions, no libm), see synthetic.cpp.
#include "nnb/cloud.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nnb::datasets {

enum class Shape { hollow_sphere, filled_sphere, hollow_cube, filled_cube };

/// The four shape names: hollow_sphere, filled_sphere, hollow_cube, filled_cube.
const std::vector<std::string>& shape_names();
/// The shape of that name, or nothing.
std::optional<Shape> parse_shape(const std::string& name);
const char* to_string(Shape shape);

/// The largest synthetic set (2.4 GB of coordinates): a larger request is a mistyped or negative count.
inline constexpr std::size_t kMaxSyntheticPoints = 100'000'000;

/// n points on (hollow) or in (filled) the shape, in metres; the same (shape, n, seed) gives the same bytes.
/// Throws InputError for n > kMaxSyntheticPoints, before allocating anything.
Cloud make_shape(Shape shape, std::size_t n_points, std::uint64_t seed);

}  // namespace nnb::datasets
