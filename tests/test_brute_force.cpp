// Brute force on small cases worked out by hand, and the API's refusal of bad input.
#include "nnb/next_float.hpp"
#include "nnb/registry.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

namespace {

using nnb::Cloud;
using nnb::InputError;
using nnb::Neighbours;

Cloud cloud(std::initializer_list<std::array<double, 3>> points) {
  Cloud c(3, static_cast<Eigen::Index>(points.size()));
  Eigen::Index i = 0;
  for (const auto& p : points) c.col(i++) << p[0], p[1], p[2];
  return c;
}

// Model: four points on the x axis at 0, 1, 3 and 6 m.
class BruteForceByHand : public ::testing::Test {
 protected:
  void SetUp() override {
    index = nnb::make_adapter("brute_force");
    index->build(model);
  }
  Cloud model = cloud({{0, 0, 0}, {1, 0, 0}, {3, 0, 0}, {6, 0, 0}});
  std::unique_ptr<nnb::SearchIndex> index;
  Neighbours out;
};

TEST_F(BruteForceByHand, KnnIsSortedNearestFirst) {
  index->knn(cloud({{2.9, 0, 0}}), 3, out);
  ASSERT_EQ(out.n_queries(), 1u);
  ASSERT_EQ(out.count(0), 3u);
  EXPECT_EQ(out.indices[0], 2u);  // 0.1 m
  EXPECT_EQ(out.indices[1], 1u);  // 1.9 m
  EXPECT_EQ(out.indices[2], 0u);  // 2.9 m
  EXPECT_NEAR(out.sq_dists[0], 0.01, 1e-12);
  EXPECT_NEAR(out.sq_dists[1], 3.61, 1e-12);
  EXPECT_NEAR(out.sq_dists[2], 8.41, 1e-12);
}

TEST_F(BruteForceByHand, KnnWithKLargerThanTheModelReturnsEveryPoint) {
  index->knn(cloud({{10, 0, 0}}), 10, out);
  ASSERT_EQ(out.count(0), 4u);
  EXPECT_EQ(out.indices[0], 3u);
  EXPECT_EQ(out.indices[3], 0u);
}

TEST_F(BruteForceByHand, RadiusIsInclusiveAtTheLimit) {
  // From x = 2: points at 2, 1, 1 and 4 m; radius 1 keeps exactly the two at 1 m.
  index->radius(cloud({{2, 0, 0}}), 1.0, out);
  ASSERT_EQ(out.count(0), 2u);
  EXPECT_EQ(out.sq_dists[0], 1.0);
  EXPECT_EQ(out.sq_dists[1], 1.0);
}

TEST_F(BruteForceByHand, RangedKeepsTheKNearestWithinTheLimit) {
  const Cloud queries = cloud({{2, 0, 0}, {4.5, 0, 0}, {20, 0, 0}});
  index->ranged(queries, 1, 1.0, out);
  ASSERT_EQ(out.n_queries(), 3u);
  ASSERT_EQ(out.count(0), 1u);  // tie at 1 m between points 1 and 2: the lower index wins
  EXPECT_EQ(out.indices[out.offsets[0]], 1u);
  EXPECT_EQ(out.count(1), 0u);  // nearest is 1.5 m away
  EXPECT_EQ(out.count(2), 0u);
  EXPECT_EQ(out.queries_with_neighbours(), 1u);

  index->ranged(queries, 2, 1.5, out);
  EXPECT_EQ(out.count(0), 2u);
  EXPECT_EQ(out.count(1), 2u);  // 3 and 6 are both 1.5 m from 4.5
  EXPECT_EQ(out.sq_dists[out.offsets[1]], 2.25);
}

TEST_F(BruteForceByHand, MaxDistZeroFindsOnlyCoincidentPoints) {
  index->ranged(cloud({{3, 0, 0}, {3.000001, 0, 0}}), 1, 0.0, out);
  EXPECT_EQ(out.count(0), 1u);
  EXPECT_EQ(out.sq_dists[0], 0.0);
  EXPECT_EQ(out.count(1), 0u);
}

TEST_F(BruteForceByHand, ThreeDimensionalDistance) {
  index->knn(cloud({{1, 2, 2}}), 1, out);  // |(0, 2, 2)| = sqrt(8) to point 1
  EXPECT_EQ(out.indices[0], 1u);
  EXPECT_DOUBLE_EQ(out.sq_dists[0], 8.0);
}

TEST_F(BruteForceByHand, RefusesBadParameters) {
  const Cloud q = cloud({{0, 0, 0}});
  EXPECT_THROW(index->knn(q, 0, out), InputError);
  EXPECT_THROW(index->ranged(q, 1, -0.1, out), InputError);
  EXPECT_THROW(index->radius(q, std::numeric_limits<double>::quiet_NaN(), out), InputError);
  EXPECT_THROW(index->knn(cloud({{0, std::numeric_limits<double>::infinity(), 0}}), 1, out), InputError);
}

TEST(BruteForce, RefusesAnEmptyOrNonFiniteModel) {
  auto index = nnb::make_adapter("brute_force");
  EXPECT_THROW(index->build(Cloud(3, 0)), InputError);
  EXPECT_THROW(index->build(cloud({{0, 0, std::numeric_limits<double>::quiet_NaN()}})), InputError);
  Neighbours out;
  EXPECT_THROW(index->knn(cloud({{0, 0, 0}}), 1, out), InputError);  // never built
}

TEST(Registry, UnknownAdapterAndParameterAreRefused) {
  EXPECT_THROW(nnb::make_adapter("no_such_library"), InputError);
  EXPECT_THROW(nnb::make_adapter("brute_force", {{"bucket_size", "10"}}), InputError);
  EXPECT_EQ(nnb::adapter_names().front(), "brute_force");
}

TEST(ParamReader, RealsAreReportedLosslesslyAndTheBucketIsDeclared) {
  nnb::ParamReader reader("x", {{"r", "0.30000000000000004"}, {"b", "12"}});
  const double third = reader.get_double("third", 1.0 / 3.0, 0.0, 1.0);
  EXPECT_EQ(reader.get_double("r", 0.0, 0.0, 1.0), 0.30000000000000004);
  EXPECT_EQ(reader.get_bucket("b", 10, 1, 100, 2, 50), 12);
  const nnb::Params effective = reader.finish();
  EXPECT_EQ(std::stod(effective.at("third")), third);  // not 6 significant digits
  EXPECT_EQ(effective.at("r"), "0.30000000000000004");
  ASSERT_TRUE(reader.bucket());
  EXPECT_EQ(reader.bucket()->name, "b");
  EXPECT_EQ(reader.bucket()->value, 12);
  EXPECT_EQ(reader.bucket()->sensible_max, 50);
}

TEST(Helpers, SortAndTruncateAndFilter) {
  Neighbours n;
  n.reset();
  n.push(4, 9.0);
  n.push(2, 1.0);
  n.push(7, 4.0);
  n.end_query();
  n.end_query();  // a query with no neighbours
  nnb::sort_and_truncate(2, n);
  ASSERT_EQ(n.count(0), 2u);
  EXPECT_EQ(n.indices[0], 2u);
  EXPECT_EQ(n.indices[1], 7u);
  EXPECT_EQ(n.count(1), 0u);
  nnb::filter_by_sq_dist(1.0, n);
  EXPECT_EQ(n.count(0), 1u);
  EXPECT_EQ(n.total(), 1u);
}

// The inline steps adapters widen their bounds by are std::nextafter's, bit for bit, at every kind of value.
template <typename Real>
void expect_steps_as_nextafter() {
  using limits = std::numeric_limits<Real>;
  const Real inf = limits::infinity();
  std::vector<Real> values = {Real(0), -Real(0), limits::denorm_min(), -limits::denorm_min(), limits::min(),
                              -limits::min(), limits::max(), -limits::max(), inf, -inf, Real(1), Real(-1),
                              Real(0.1), Real(-2.5e-3), Real(6.02e23), std::nextafter(limits::min(), Real(0))};
  for (int e = limits::min_exponent - limits::digits; e < limits::max_exponent; e += 7) {
    values.push_back(std::ldexp(Real(1.37), e));
    values.push_back(-std::ldexp(Real(1.37), e));
  }
  const auto same = [](Real a, Real b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (const Real x : values) {
    EXPECT_TRUE(same(nnb::next_up(x), std::nextafter(x, inf))) << x;
    EXPECT_TRUE(same(nnb::next_down(x), std::nextafter(x, -inf))) << x;
  }
  EXPECT_TRUE(std::isnan(nnb::next_up(limits::quiet_NaN())));
  EXPECT_TRUE(std::isnan(nnb::next_down(limits::quiet_NaN())));
}

TEST(Helpers, NextUpAndDownAreNextafter) {
  expect_steps_as_nextafter<double>();
  expect_steps_as_nextafter<float>();
}

// Threads are kept between batches, but a process forked from one that has them gets none of them: the
// child answers on threads of its own, as the parent did, and exits (its pools let go, not joined).
TEST(Threads, AForkedChildAnswersOnThreadsOfItsOwnAndExits) {
  Cloud model(3, 3000), queries(3, 2000);
  for (Eigen::Index i = 0; i < model.cols(); ++i) model.col(i) << 0.001 * i, std::sin(0.01 * i), 0.0;
  for (Eigen::Index i = 0; i < queries.cols(); ++i) queries.col(i) << 0.0015 * i, std::cos(0.02 * i), 0.1;
  auto index = nnb::make_adapter("brute_force");
  index->build(model);
  index->set_threads(2);
  Neighbours parent;
  index->knn(queries, 2, parent);  // the parent's pool starts its threads
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::alarm(60);  // a child waiting for threads it does not have is killed, and the test fails
    Neighbours child;
    index->knn(queries, 2, child);
    std::exit(child.indices == parent.indices && child.sq_dists == parent.sq_dists ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the child was killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the child's answers differ from the parent's";
}

}  // namespace
