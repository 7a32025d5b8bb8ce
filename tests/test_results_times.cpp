// A repetition's time is written in the file's time unit (microseconds) and read back in seconds; written
// again, it must be the same number, or a record a child hands its parent (and --resume rewrites) would not
// be written as it was read.
#include "results_json.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

namespace {

using nnb::bench::results::json;
using nnb::bench::results::ordered_json;

// The real_time field as the file holds it: put_times, then the text and back.
double written(double seconds) {
  ordered_json j;
  nnb::bench::results::put_times(j, seconds, seconds);
  return json::parse(j.dump()).at("real_time").get<double>();
}

// That field read back in seconds, in the unit put_times wrote it in.
double read_back(double value) { return nnb::bench::results::seconds_from(value, nnb::bench::results::time_unit); }

}  // namespace

TEST(ResultsTimes, EveryWrittenTimeReadsBackToTheSameNumber) {
  std::mt19937_64 bits_of(20261204);
  int checked = 0;
  for (int i = 0; i < 300000; ++i) {
    const std::uint64_t bits = bits_of() >> 1;  // a positive double of any exponent, subnormals included
    double seconds;
    std::memcpy(&seconds, &bits, sizeof seconds);
    if (!std::isfinite(1e6 * seconds)) continue;
    const double value = written(seconds);
    ASSERT_EQ(written(read_back(value)), value) << "a time of " << seconds << " s";
    ++checked;
  }
  EXPECT_GT(checked, 250000);
}

TEST(ResultsTimes, EveryUnitIsReadInSeconds) {
  EXPECT_EQ(nnb::bench::results::seconds_from(1500, "ms"), 1.5);
  EXPECT_EQ(nnb::bench::results::seconds_from(2.5e6, "us"), 2.5);
  EXPECT_EQ(nnb::bench::results::seconds_from(3e9, "ns"), 3.0);
  EXPECT_EQ(nnb::bench::results::seconds_from(4, "s"), 4.0);
  EXPECT_THROW(nnb::bench::results::seconds_from(1, "min"), json::exception);
}
