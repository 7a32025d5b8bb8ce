#pragma once
// The adjacent values of a double or float, as std::nextafter(x, +-inf) gives them, inline: adapters widen
// bounds by one ulp for every query, and a call into libm there was a few per cent of a fast library's search.
#include <cstdint>
#include <cstring>
#include <limits>

namespace nnb {

namespace detail {
template <typename Real, typename Bits>
Real next_up(Real x) {
  if (!(x < std::numeric_limits<Real>::infinity())) return x;
  if (x == Real(0)) return std::numeric_limits<Real>::denorm_min();
  Bits bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits = x > Real(0) ? bits + 1 : bits - 1;  // the magnitude's bits count in order, the sign bit apart
  std::memcpy(&x, &bits, sizeof bits);
  return x;
}
}  // namespace detail

/// The least value above x (x itself for +inf and NaN), as std::nextafter(x, +inf).
inline double next_up(double x) { return detail::next_up<double, std::uint64_t>(x); }
inline float next_up(float x) { return detail::next_up<float, std::uint32_t>(x); }

/// The greatest value below x (x itself for -inf and NaN), as std::nextafter(x, -inf).
inline double next_down(double x) { return -next_up(-x); }
inline float next_down(float x) { return -next_up(-x); }

}  // namespace nnb
