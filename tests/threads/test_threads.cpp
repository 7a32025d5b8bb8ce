// A batch split over threads answers exactly as on one thread, for every adapter: the rows in the caller's
// order, the same indices and the same distances, in every query kind and strategy. Adapters declared
// Concurrency::queries run their slices side by side (under ThreadSanitizer too, see subjects_tsan.cpp),
// Concurrency::library ones hand the threads to their library, Concurrency::single ones stay on one.
#include "ours_rows.hpp"
#include "subjects.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <initializer_list>
#include <random>
#include <stdexcept>
#include <thread>

namespace {

using nnb::Cloud;
using nnb::Neighbours;
using nnb::testing::ThreadSubject;

// Points in a 1 m cube, a tenth of them repeated (ties), and queries near and far from them.
Cloud cube_points(Eigen::Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> coord(0.0, 1.0);
  Cloud points(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (i % 10 == 9) points.col(i) = points.col(i / 2);
    else points.col(i) = Eigen::Vector3d(coord(rng), coord(rng), coord(rng));
  }
  return points;
}

bool same_rows(const Neighbours& a, const Neighbours& b) {
  return a.offsets == b.offsets && a.indices == b.indices && a.sq_dists == b.sq_dists;
}

class Threads : public ::testing::TestWithParam<ThreadSubject> {
 protected:
  // Every query kind on index (with threads set) against the same on one thread.
  void expect_same_answers(const nnb::SearchIndex& one, const nnb::SearchIndex& many, const Cloud& queries) {
    const std::string where = GetParam().name + " on " + std::to_string(many.threads()) + " threads";
    Neighbours expected, got;
    const nnb::AdapterInfo& info = one.info();
    const int more = info.exact ? 4 : 1;  // the approximate adapter finds one neighbour only
    if (info.knn != nnb::Strategy::unsupported) {
      for (int k : {1, more}) {
        one.knn(queries, k, expected);
        many.knn(queries, k, got);
        EXPECT_TRUE(same_rows(expected, got)) << where << ": knn k=" << k;
      }
    }
    if (info.radius != nnb::Strategy::unsupported) {
      one.radius(queries, 0.06, expected);
      many.radius(queries, 0.06, got);
      EXPECT_TRUE(same_rows(expected, got)) << where << ": radius";
    }
    if (info.ranged == nnb::Strategy::unsupported) return;
    for (const nnb::Strategy s : info.strategies(nnb::SearchKind::ranged)) {
      for (double d : {0.03, 0.2}) {
        one.ranged(queries, more, d, expected, s);
        many.ranged(queries, more, d, got, s);
        EXPECT_TRUE(same_rows(expected, got)) << where << ": ranged " << nnb::to_string(s) << " at " << d << " m";
      }
    }
    std::vector<nnb::PointIndex> hints(static_cast<std::size_t>(queries.cols()));
    for (std::size_t q = 0; q < hints.size(); ++q) hints[q] = q % 3 == 0 ? nnb::kNoHint : static_cast<nnb::PointIndex>(q);
    one.ranged_hinted(queries, 0.1, hints, expected);
    many.ranged_hinted(queries, 0.1, hints, got);
    EXPECT_TRUE(same_rows(expected, got)) << where << ": ranged_hinted";
  }
};

TEST_P(Threads, AnswerAsOnOneThread) {
  const Cloud model = cube_points(3000, 1);
  // More than kMinQueriesPerThread a thread for every thread count below, and an uneven split.
  const Cloud queries = 1.2 * cube_points(2 * 5 * nnb::SearchIndex::kMinQueriesPerThread + 7, 2);
  auto one = GetParam().create();
  one->build(model);
  const nnb::Concurrency concurrency = one->info().concurrency;
  for (int threads : {2, 5}) {
    auto many = GetParam().create();
    many->set_threads(threads);
    many->build(model);
    EXPECT_EQ(many->threads_used(), concurrency == nnb::Concurrency::single ? 1 : threads)
        << nnb::to_string(concurrency);
    expect_same_answers(*one, *many, queries);
    if (concurrency == nnb::Concurrency::single) break;  // one thread however many are asked for
  }
}

TEST_P(Threads, SmallBatchesStayWhole) {
  const Cloud model = cube_points(500, 3);
  const Cloud queries = cube_points(nnb::SearchIndex::kMinQueriesPerThread + 1, 4);
  auto one = GetParam().create();
  auto many = GetParam().create();
  many->set_threads(8);
  one->build(model);
  many->build(model);
  expect_same_answers(*one, *many, queries);
}

// Adapters that build on threads build the index they build on one: the same answers. The cloud is large
// enough for a threaded build to start threads (ours: 2^17 points).
TEST_P(Threads, BuildOnThreadsAnswersAsOnOne) {
  auto probe = GetParam().create();
  if (!probe->info().builds_on_threads) return;  // builds on one thread: nothing more to compare
  const Cloud model = cube_points(150000, 7);
  const Cloud queries = cube_points(2000, 8);
  probe->build(model);
  auto many = GetParam().create();
  many->set_threads(3);
  many->build(model);
  EXPECT_EQ(many->build_threads_used(), 3);
  Neighbours expected, got;
  probe->ranged(queries, 2, 0.02, expected);
  many->ranged(queries, 2, 0.02, got);
  EXPECT_TRUE(same_rows(expected, got));
}

TEST(ThreadsAsked, OutsideOneToMaxIsRefused) {
  auto index = nnb::testing::thread_subjects().front().create();
  EXPECT_THROW(index->set_threads(0), nnb::InputError);
  EXPECT_THROW(index->set_threads(nnb::SearchIndex::kMaxThreads + 1), nnb::InputError);
  EXPECT_EQ(index->threads(), 1);
  index->set_threads(nnb::SearchIndex::kMaxThreads);
  EXPECT_EQ(index->threads(), nnb::SearchIndex::kMaxThreads);
}

// A bad query (caught before any slice runs) is refused as on one thread.
TEST(ThreadsAsked, BadQueriesAreRefusedBeforeSplitting) {
  auto index = nnb::testing::thread_subjects().front().create();
  index->set_threads(4);
  index->build(cube_points(100, 5));
  Cloud queries = cube_points(4 * nnb::SearchIndex::kMinQueriesPerThread, 6);
  queries(1, 700) = std::numeric_limits<double>::quiet_NaN();
  Neighbours out;
  EXPECT_THROW(index->ranged(queries, 1, 0.1, out), nnb::InputError);
}

// Rows answered in another order land after the rows out holds, each at its own query.
TEST(RowsInOrder, RowsReturnToTheCallersOrder) {
  Neighbours out;
  out.reset();
  out.push(7, 0.5);
  out.end_query();
  Neighbours answered;
  answered.reset();
  // Answered order: queries 2, 0, 3, 1; query q has q neighbours.
  const std::vector<nnb::PointIndex> order{2, 0, 3, 1};
  for (const nnb::PointIndex q : order) {
    for (nnb::PointIndex j = 0; j < q; ++j) answered.push(10 * q + j, 0.1 * q);
    answered.end_query();
  }
  nnb::append_rows_in_order(answered, order, out);
  ASSERT_EQ(out.n_queries(), 5u);
  EXPECT_EQ(out.count(0), 1u);
  for (std::size_t q = 0; q < 4; ++q) {
    ASSERT_EQ(out.count(q + 1), q);
    for (std::size_t j = 0; j < q; ++j) {
      EXPECT_EQ(out.indices[out.offsets[q + 1] + j], 10 * q + j);
      EXPECT_EQ(out.sq_dists[out.offsets[q + 1] + j], 0.1 * static_cast<double>(q));
    }
  }
  const Neighbours before = out;
  EXPECT_THROW(nnb::append_rows_in_order(answered, {2, 0, 3}, out), std::logic_error);
  EXPECT_TRUE(same_rows(before, out));
}

// Runs body(team) on a team of `size` threads, this one member 0; rethrows what a body threw.
template <class Body>
void on_team(int size, Body body) {
  nnb::Team::Shared shared;
  std::vector<std::thread> others;
  for (int member = 1; member < size; ++member) others.emplace_back([&, member] { body(nnb::Team(member, shared)); });
  shared.size.store(size, std::memory_order_release);
  body(nnb::Team(0, shared));
  for (auto& other : others) other.join();
  if (shared.error) std::rethrow_exception(shared.error);
}

// Each phase sees what every member wrote in the phase before, round after round (teams larger than the
// machine's cores included: the barrier then yields).
TEST(Team, EachPhaseSeesThePreviousPhasesWrites) {
  for (const int size : {2, 3, 7}) {
    std::vector<long> written(static_cast<std::size_t>(size), 0);
    std::vector<int> wrong(static_cast<std::size_t>(size), 0);
    on_team(size, [&](const nnb::Team& team) {
      const auto me = static_cast<std::size_t>(team.member());
      for (long round = 1; round <= 200; ++round) {
        team.phase([&] { written[me] = round * long(me + 1); });
        team.phase([&] {
          long sum = 0;
          for (const long value : written) sum += value;
          if (sum != round * size * (size + 1) / 2) ++wrong[me];
        });
      }
    });
    EXPECT_EQ(wrong, std::vector<int>(static_cast<std::size_t>(size), 0)) << size << " members";
  }
}

// A body that throws does not leave the others waiting: the phase ends, the later bodies are skipped, and
// the exception reaches the caller.
TEST(Team, AThrowingBodySkipsTheRestAndIsRethrown) {
  std::atomic<int> later{0};
  EXPECT_THROW(on_team(3,
                       [&](const nnb::Team& team) {
                         team.phase([&] {
                           if (team.member() == 1) throw std::runtime_error("member 1 fails");
                         });
                         team.phase([&] { ++later; });
                       }),
               std::runtime_error);
  EXPECT_EQ(later.load(), 0);
}

// The members' shares cover the items once, in order.
TEST(Team, SharesCoverEveryItemOnce) {
  for (const int size : {1, 2, 5}) {
    for (const std::size_t n : {0u, 1u, 4u, 1001u}) {
      std::size_t next = 0;
      for (int member = 0; member < size; ++member) {
        nnb::Team::Shared shared;
        shared.size = size;
        const auto share = nnb::Team(member, shared).share(n);
        EXPECT_EQ(share.first, next) << n << " items, member " << member << " of " << size;
        next = share.second;
      }
      EXPECT_EQ(next, n);
    }
  }
}

// The Morton order a team finds (each member the box and keys of its share) is the one ours::morton_order
// finds alone, each member sorting its share and merging its part: shares small and large (under and
// over 2^15 keys), and repeated points, whose equal codes in every share keep the caller's order.
TEST(Team, MortonOrderOnATeamIsTheSerialOne) {
  for (const Eigen::Index n : {Eigen::Index(300), Eigen::Index(5000), Eigen::Index(40000), Eigen::Index(70000)}) {
    const Cloud scattered = cube_points(n, 9);
    Cloud repeated(3, n);
    for (Eigen::Index i = 0; i < n; ++i) repeated.col(i) = scattered.col(i % 37);
    for (const Cloud* queries : std::initializer_list<const Cloud*>{&scattered, &repeated}) {
      ours::QueryOrder alone;
      ours::morton_order(queries->data(), static_cast<std::size_t>(n), alone);
      for (const int size : {2, 3, 7}) {
        std::vector<nnb::PointIndex> order(static_cast<std::size_t>(n));
        on_team(size, [&](const nnb::Team& team) { nnb::adapters::ours_rows::morton_order_on_team(*queries, team, order); });
        EXPECT_EQ(order, alone.order) << n << " queries on " << size << " threads"
                                      << (queries == &repeated ? ", repeated points" : "");
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EveryAdapter, Threads, ::testing::ValuesIn(nnb::testing::thread_subjects()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
