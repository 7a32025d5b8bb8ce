// run_sweep's progress counts every cell once a round: a cell's rounds counted when a run starts plus the later
// rounds that count it without running it must make the experiment's rounds, however the run was cut.
#include "sweep/runner.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

namespace {

using nnb::sweep::Experiment;
using nnb::sweep::Record;

Experiment three_rounds() {
  Experiment e;
  e.rounds = 3;
  e.budget_s = 0.5;
  return e;
}

Record timed(std::vector<double> wall_each_s) {
  Record r;
  r.type = Record::Type::sweep;
  r.rounds = static_cast<int>(wall_each_s.size());
  r.wall_each_s = std::move(wall_each_s);
  return r;
}

// What a run resumed with this record counts for it: at the start, then in each later round it does not run.
std::size_t counted_by_resumed_run(const Record& r, const Experiment& e) {
  std::size_t n = nnb::sweep::rounds_counted(r, e);
  for (int round = 2; round <= e.rounds; ++round) n += nnb::sweep::settled_in_round(r, round, e);
  return n;
}

TEST(SweepProgress, CellEndedByTheBudgetInItsSecondRoundCountsThreeRounds) {
  const Experiment e = three_rounds();
  const Record r = timed({0.45, 0.6});  // within the budget, then over it: ended in round 2
  EXPECT_FALSE(nnb::sweep::settled_in_round(r, 2, e));
  EXPECT_TRUE(nnb::sweep::settled_in_round(r, 3, e));
  EXPECT_EQ(counted_by_resumed_run(r, e), 3u);
}

TEST(SweepProgress, CellEndedByTheBudgetInItsFirstRoundCountsThreeRounds) {
  const Experiment e = three_rounds();
  const Record r = timed({1.2});  // over twice the budget at once
  EXPECT_TRUE(nnb::sweep::settled_in_round(r, 2, e));
  EXPECT_EQ(counted_by_resumed_run(r, e), 3u);
}

TEST(SweepProgress, SkippedCellCountsThreeRounds) {
  const Experiment e = three_rounds();
  Record r;
  r.skipped = "over budget";
  EXPECT_EQ(counted_by_resumed_run(r, e), 3u);
}

TEST(SweepProgress, FinishedCellCountsItsRoundsAndIsNotCountedAgain) {
  const Experiment e = three_rounds();
  const Record r = timed({0.1, 0.1, 0.1});
  EXPECT_EQ(counted_by_resumed_run(r, e), 3u);
}

TEST(SweepProgress, CellStillDueIsNotSettled) {
  const Experiment e = three_rounds();
  const Record r = timed({0.1});  // runs in rounds 2 and 3, where the run counts it
  EXPECT_FALSE(nnb::sweep::settled_in_round(r, 2, e));
  EXPECT_FALSE(nnb::sweep::settled_in_round(r, 3, e));
  EXPECT_EQ(nnb::sweep::rounds_counted(r, e), 1u);
}

}  // namespace
