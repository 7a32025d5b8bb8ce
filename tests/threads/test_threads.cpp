// A batch split over threads answers exactly as on one thread, for every adapter: the rows in the caller's
// order, the same indices and the same distances, in every query kind and strategy. Adapters declared
// Concurrency::queries run their slices side by side (under ThreadSanitizer too, see subjects_tsan.cpp),
// Concurrency::library ones hand the threads to their library, Concurrency::single ones stay on one.
#include "subjects.hpp"

#include <gtest/gtest.h>

#include <random>

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

// Rows answered in pieces, in another order, land after the rows out holds, each at its own query.
TEST(RowsInOrder, PiecesReturnToTheCallersOrder) {
  Neighbours out;
  out.reset();
  out.push(7, 0.5);
  out.end_query();
  std::vector<Neighbours> pieces(2);
  for (auto& piece : pieces) piece.reset();
  // Answered order: queries 2, 0 (first piece), then 3, 1 (second); query q has q neighbours.
  const std::vector<nnb::PointIndex> order{2, 0, 3, 1};
  for (std::size_t s = 0; s < order.size(); ++s) {
    Neighbours& piece = pieces[s / 2];
    for (nnb::PointIndex j = 0; j < order[s]; ++j) piece.push(10 * order[s] + j, 0.1 * order[s]);
    piece.end_query();
  }
  nnb::append_rows_in_order(pieces, order, out);
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
  std::vector<Neighbours> short_of_one(1, pieces[0]);
  EXPECT_THROW(nnb::append_rows_in_order(short_of_one, order, out), std::logic_error);
  EXPECT_TRUE(same_rows(before, out));
}

INSTANTIATE_TEST_SUITE_P(EveryAdapter, Threads, ::testing::ValuesIn(nnb::testing::thread_subjects()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
