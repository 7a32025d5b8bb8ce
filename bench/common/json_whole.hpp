#pragma once
// Whole numbers read from JSON input files: 1.5, -1 or 2^31 for an int is refused with one line, never
// truncated or wrapped as nlohmann's get<int>() would.
#include "nnb/cloud.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

namespace nnb::bench {

/// value as Int; InputError naming `what` when it is not a whole number within Int's range.
template <class Int>
Int whole_number(const nlohmann::json& value, const std::string& what) {
  using limits = std::numeric_limits<Int>;
  const std::string said = what + " = " + value.dump();
  if (value.is_number_unsigned()) {
    if (value.get<std::uint64_t>() > static_cast<std::uint64_t>(limits::max())) throw InputError(said + " is too large");
    return static_cast<Int>(value.get<std::uint64_t>());
  }
  if (value.is_number_integer()) {  // negative
    if (value.get<std::int64_t>() < static_cast<std::int64_t>(limits::min())) throw InputError(said + " is out of range");
    return static_cast<Int>(value.get<std::int64_t>());
  }
  if (!value.is_number_float() || std::floor(value.get<double>()) != value.get<double>()) {
    throw InputError(said + " is not a whole number");
  }
  const double d = value.get<double>();
  if (d < static_cast<double>(limits::min()) || d >= static_cast<double>(limits::max())) {
    throw InputError(said + " is out of range");
  }
  return static_cast<Int>(d);
}

}  // namespace nnb::bench
