// The sweep writes a call's output memory before timing it: answers written within that room must fault in
// no fresh page, or every call of a cell timed once a round would pay the kernel's first touch; a call that
// outgrew the room is made again, and the call that counts faults in none.
#include "sweep/memory.hpp"

#include <gtest/gtest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <cstddef>
#include <vector>

namespace {

long minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

// Answers as an adapter writes them: reset, then rows of pushes.
void answer(std::size_t n_queries, std::size_t per_query, nnb::Neighbours& out) {
  out.reset();
  for (std::size_t q = 0; q < n_queries; ++q) {
    for (std::size_t i = 0; i < per_query; ++i) out.push(static_cast<nnb::PointIndex>(i), 0.25);
    out.end_query();
  }
}

}  // namespace

TEST(TouchOutput, EmptiesTheOutputAndKeepsItsRoom) {
  nnb::Neighbours out;
  answer(10, 3, out);
  nnb::sweep::touch_output(1000, 50000, out);
  EXPECT_EQ(out.n_queries(), 0u);
  EXPECT_EQ(out.total(), 0u);
  EXPECT_GE(out.offsets.capacity(), 1001u);
  EXPECT_GE(out.indices.capacity(), 50000u);
  EXPECT_GE(out.sq_dists.capacity(), 50000u);
}

TEST(TouchOutput, AnswersWithinItsRoomFaultInNoFreshPage) {
  // 16 Mi answers, 192 MiB: far above the size below which malloc reuses freed memory.
  constexpr std::size_t kQueries = std::size_t{1} << 20, kPerQuery = 16;
  const std::size_t pages = kQueries * kPerQuery * (sizeof(nnb::PointIndex) + sizeof(double)) /
                            static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  nnb::Neighbours out;
  nnb::sweep::touch_output(kQueries, kQueries * kPerQuery, out);
  const long before = minor_faults();
  answer(kQueries, kPerQuery, out);
  EXPECT_LT(minor_faults() - before, static_cast<long>(pages / 100)) << "of " << pages << " pages";
  EXPECT_EQ(out.total(), kQueries * kPerQuery);
}

TEST(OutputRoom, KnnGetsKAQuery) {
  EXPECT_EQ(nnb::sweep::output_room(nnb::SearchKind::knn, 8, 1000, 0, 0), 8000u);
}

TEST(OutputRoom, RadiusFollowsTheEarlierRoundElseTheCallBefore) {
  EXPECT_EQ(nnb::sweep::output_room(nnb::SearchKind::radius, 0, 1000, 0, 0), 0u);
  EXPECT_EQ(nnb::sweep::output_room(nnb::SearchKind::radius, 0, 1000, 0, 7000), 7000u);
  EXPECT_EQ(nnb::sweep::output_room(nnb::SearchKind::radius, 0, 1000, 9000, 7000), 9000u);
}

TEST(OutputRoom, RangedIsOneAQueryAtLeastAndKAQueryAtMost) {
  using nnb::SearchKind;
  EXPECT_EQ(nnb::sweep::output_room(SearchKind::ranged, 1, 1000, 0, 0), 1000u);
  EXPECT_EQ(nnb::sweep::output_room(SearchKind::ranged, 1, 1000, 5000, 5000), 1000u);
  EXPECT_EQ(nnb::sweep::output_room(SearchKind::ranged, 5000, 1000, 0, 0), 1000u);
  EXPECT_EQ(nnb::sweep::output_room(SearchKind::ranged, 5000, 1000, 0, 30000), 30000u);
  EXPECT_EQ(nnb::sweep::output_room(SearchKind::ranged, 5000, 1000, 42000, 30000), 42000u);
  // A large k with a small answer: room for the answer, not for 5 million neighbours.
  EXPECT_LT(nnb::sweep::output_room(SearchKind::ranged, 5000, 1000, 1200, 0), 5000u * 1000u / 100);
}

TEST(CallWithinRoom, ACallWithinTheRoomIsMadeOnce) {
  nnb::Neighbours out;
  nnb::sweep::touch_output(1000, 4000, out);
  std::size_t room = 4000, calls = 0;
  const int counted = nnb::sweep::call_within_room([&] { answer(1000, 4, out); return ++calls; }, out, room);
  EXPECT_EQ(calls, 1u);
  EXPECT_EQ(counted, 1);
  EXPECT_EQ(room, 4000u);
}

TEST(CallWithinRoom, ACallThatOutgrewTheRoomIsMadeAgainAndTheSecondFaultsInNoFreshPage) {
  // As the first round's radius call after a smaller one: room for 1 Mi answers, 16 Mi written (192 MiB).
  constexpr std::size_t kQueries = std::size_t{1} << 20, kPerQuery = 16;
  const std::size_t pages = kQueries * kPerQuery * (sizeof(nnb::PointIndex) + sizeof(double)) /
                            static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  nnb::Neighbours out;
  std::size_t room = kQueries;
  nnb::sweep::touch_output(kQueries, room, out);
  std::vector<long> faults;
  const long counted = nnb::sweep::call_within_room(
      [&] {
        const long before = minor_faults();
        answer(kQueries, kPerQuery, out);
        faults.push_back(minor_faults() - before);
        return faults.back();
      },
      out, room);
  ASSERT_EQ(faults.size(), 2u);
  EXPECT_EQ(counted, faults[1]);
  EXPECT_LT(counted, static_cast<long>(pages / 100)) << "of " << pages << " pages";
  EXPECT_EQ(room, kQueries * kPerQuery);
}
