// run_sweep's progress counts every cell once a round: what a run counts for a cell at its start plus what it
// counts as the rounds pass must make the experiment's rounds, however the run was cut, and a resumed run must
// not count its settled cells as work done in it (its ETA comes from that work).
#include "sweep/runner.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

namespace {

using nnb::sweep::Experiment;
using nnb::sweep::Record;
using nnb::sweep::rounds_counted;
using nnb::sweep::settled;
using nnb::sweep::settled_in_round;

Experiment three_rounds() {
  Experiment e;
  e.rounds = 3;
  e.budget_s = 0.5;
  return e;
}

// A cell as recorded after one call a round with these wall times.
Record timed(std::vector<double> wall_each_s) {
  Record r;
  r.type = Record::Type::sweep;
  r.rounds = static_cast<int>(wall_each_s.size());
  r.wall_each_s = std::move(wall_each_s);
  return r;
}

Record skipped() {
  Record r;
  r.skipped = "over budget: 0.6 s at max_dist 0.10 > 0.5 s";
  return r;
}

TEST(SweepProgress, SettledCellsCountInFullAtTheStart) {
  const Experiment e = three_rounds();
  for (const Record& r : {skipped(), timed({1.2}), timed({0.45, 0.6}), timed({0.45, 0.4, 0.7})}) {
    EXPECT_TRUE(settled(r, e));
    EXPECT_EQ(rounds_counted(r, e), 3u);
  }
}

TEST(SweepProgress, UnsettledCellsCountTheirRoundsSoFar) {
  const Experiment e = three_rounds();
  EXPECT_FALSE(settled(timed({0.1}), e));
  EXPECT_EQ(rounds_counted(timed({0.1}), e), 1u);
  EXPECT_EQ(rounds_counted(timed({0.45, 0.4}), e), 2u);  // within the budget: runs again
  EXPECT_EQ(rounds_counted(timed({0.1, 0.1, 0.1}), e), 3u);
}

// A cell that settles during the run is counted by the rounds it ran in and then by each later round it skips.
TEST(SweepProgress, CellEndedInItsSecondRoundIsCountedByTheThirdOnly) {
  const Experiment e = three_rounds();
  const Record r = timed({0.45, 0.6});
  EXPECT_FALSE(settled_in_round(r, 2, e));  // it ran in round 2, which counted it
  EXPECT_TRUE(settled_in_round(r, 3, e));
}

TEST(SweepProgress, CellEndedInItsFirstRoundIsCountedByEachLaterRound) {
  const Experiment e = three_rounds();
  const Record r = timed({1.2});  // over twice the budget at once
  EXPECT_TRUE(settled_in_round(r, 2, e));
  EXPECT_TRUE(settled_in_round(r, 3, e));
  EXPECT_TRUE(settled_in_round(skipped(), 2, e));
}

TEST(SweepProgress, CellStillDueIsNotSettled) {
  const Experiment e = three_rounds();
  const Record r = timed({0.1});  // runs in rounds 2 and 3, where the run counts it
  EXPECT_FALSE(settled_in_round(r, 2, e));
  EXPECT_FALSE(settled_in_round(r, 3, e));
}

}  // namespace
