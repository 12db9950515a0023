// The one rule for time stamps (fw::TimeLine), the one pacing rule (fw::ReplayClock), a flight
// propagated across any time, and the world state read in publication order whatever the stamps.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "framework_api/replay_clock.h"
#include "framework_api/time_line.h"
#include "framework_api/world_state.h"

namespace {

using Step = fw::TimeLine::Step;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

TEST(TimeLine, ClassifiesEveryKindOfStamp) {
  fw::TimeLine line(1.0);
  EXPECT_EQ(line.next(kNan), Step::kNotFinite);
  EXPECT_EQ(line.next(100.0), Step::kFirst);
  EXPECT_EQ(line.next(100.033), Step::kOnward);
  EXPECT_EQ(line.next(100.033), Step::kLate) << "a repeated stamp";
  EXPECT_EQ(line.next(100.0), Step::kLate) << "a little back";
  EXPECT_EQ(line.next(kInf), Step::kNotFinite);
  EXPECT_EQ(line.next(-kInf), Step::kNotFinite);
  EXPECT_DOUBLE_EQ(*line.newest_s(), 100.033) << "neither late nor unusable stamps move the newest";
  EXPECT_EQ(line.next(1e9 + 100.0), Step::kJump);
  EXPECT_NE(line.describe(Step::kJump, 1e9 + 100.0).find("jumps by 999999999.967 s"), std::string::npos)
      << line.describe(Step::kJump, 1e9 + 100.0);
  EXPECT_EQ(line.next(1e9 + 100.033), Step::kOnward) << "the new time line goes on from the jump";
  EXPECT_EQ(line.next(5.0), Step::kJump) << "backwards by more than the limit";
  EXPECT_EQ(line.next(5.5), Step::kOnward);
  EXPECT_EQ(line.next(5.5 + 1e-9), Step::kLate) << "the same moment: no sensor sends frames a nanosecond apart";
  EXPECT_EQ(line.next(5.5 + 2 * fw::kMinStampStep_s), Step::kOnward);
}

TEST(ReplayClock, ATimeThatJumpsEitherWayIsDueAtOnceAndThePaceGoesOnFromIt) {
  // Were a jump waited through, this test would not end.
  fw::ReplayClock clock(/*realtime=*/true);
  EXPECT_EQ(clock.waitFor(10.0), fw::ReplayClock::Pace::kDue);
  EXPECT_EQ(clock.waitFor(1e9), fw::ReplayClock::Pace::kRebased);
  EXPECT_EQ(clock.waitFor(-1e6), fw::ReplayClock::Pace::kRebased);
  EXPECT_EQ(clock.waitFor(kNan), fw::ReplayClock::Pace::kDue);
  // 0.9 s after the new anchor is not due yet: the pace goes on from -1e6 s.
  EXPECT_EQ(clock.waitFor(-1e6 + 0.9, 0.01), fw::ReplayClock::Pace::kNotYet);
}

TEST(ReplayClock, APinnedClockKeepsToTheWallClockWhateverComesFirst) {
  // Scene time 0 is 5 s from now: waited for (not re-based on, as a free clock would), a slice at a
  // time; what is past is due at once, and a far jump is not a new pace either.
  const double start_s = fw::wallClockNow_s() + 5.0;
  fw::ReplayClock clock(/*realtime=*/true, start_s);
  EXPECT_EQ(clock.waitFor(0.0, 0.01), fw::ReplayClock::Pace::kNotYet);
  EXPECT_EQ(clock.waitFor(-10.0), fw::ReplayClock::Pace::kDue);
  EXPECT_EQ(clock.waitFor(-1e6), fw::ReplayClock::Pace::kDue);
  EXPECT_EQ(clock.waitFor(0.0, 0.01), fw::ReplayClock::Pace::kNotYet) << "still pinned to the wall clock";
}

TEST(ReplayClock, ClocksThatShareTheirHostsPaceBringOneMomentDueTogetherWhicheverStartsFirst) {
  fw::SharedPace host_pace;
  fw::ReplayClock omni(/*realtime=*/true, &host_pace), kinect(/*realtime=*/true, &host_pace);
  EXPECT_EQ(omni.waitFor(100.0), fw::ReplayClock::Pace::kDue);
  // The Kinect's first frame is half a second after the omni's first image: not yet due, where a
  // clock of its own would have anchored it now, and due at the omni's moment for it.
  EXPECT_EQ(kinect.waitFor(100.5, 0.01), fw::ReplayClock::Pace::kNotYet);
  ASSERT_TRUE(kinect.dueWall_s(100.5));
  EXPECT_EQ(*kinect.dueWall_s(100.5), *omni.dueWall_s(100.5));
  // A source on another clock (its first item 10 minutes off the shared pace) keeps its own pace,
  // without a warning's re-base.
  fw::ReplayClock recorded(/*realtime=*/true, &host_pace);
  EXPECT_EQ(recorded.waitFor(700.0), fw::ReplayClock::Pace::kDue);
  EXPECT_EQ(recorded.waitFor(700.5, 0.01), fw::ReplayClock::Pace::kNotYet);
}

TEST(BallTrajectory, PropagatesAcrossAnyTimeWithoutAStepPerFrame) {
  fw::BallTrajectory flight;
  flight.state = fw::BallState::kAir;
  flight.position_m = {0.0, 0.0, 1.0};
  flight.velocity_mps = {0.0, 5.0, 5.0};
  flight.drag_per_m = 0.02;
  flight.curve_radps = 0.1;
  flight.time_s = 0.0;
  // 1e12 s would take 5e13 steps of 20 ms: it returns, and the ball is where it was after 10 s of
  // flight plus the rest at that speed (terminal speed under drag: about 22 m/s).
  const Eigen::Vector3d far = flight.positionAt(1e12);
  EXPECT_TRUE(far.allFinite());
  EXPECT_LT(far.z(), -1e12);
  EXPECT_FALSE(flight.positionAt(kNan).allFinite()) << "no position for no time";
  EXPECT_FALSE(flight.positionAt(kInf).allFinite());
  // An ordinary second of flight is as before.
  EXPECT_NEAR(flight.positionAt(1.0).y(), 4.6, 0.2);
}

TEST(WorldState, AReaderSeesEachMeasurementOnceInPublicationOrderWhateverItsStamp) {
  fw::WorldState world;
  std::uint64_t cursor = 0;
  const auto ballStamped = [](double t_s) {
    return fw::BallObservation::inRobotFrame({0.0, 1.0, 0.5}, Eigen::Matrix3d::Identity() * 0.01, fw::BallState::kAir,
                                             "kinect3d", fw::Stamp{t_s, t_s});
  };
  const auto timeOf = [](const fw::WorldState::Measurement& measurement) {
    return std::get<fw::BallFrame>(measurement).stamp.source_time_s;
  };
  world.publishBalls({ballStamped(100.0)});
  world.publishBalls({ballStamped(1e9)});
  ASSERT_EQ(world.measurementsSince(&cursor).size(), 2u);
  EXPECT_TRUE(world.measurementsSince(&cursor).empty()) << "each measurement once";
  world.publishBalls({ballStamped(5.0)});  // back by a billion seconds
  world.publishBalls({ballStamped(kNan)});
  const std::vector<fw::WorldState::Measurement> frames = world.measurementsSince(&cursor);
  ASSERT_EQ(frames.size(), 2u) << "a stamp that goes back is still new to the reader";
  EXPECT_DOUBLE_EQ(timeOf(frames[0]), 5.0);
  EXPECT_TRUE(std::isnan(timeOf(frames[1])));
  // A reader that falls far behind gets the newest kMeasurementsKept.
  for (std::size_t i = 0; i < 2 * fw::WorldState::kMeasurementsKept; ++i) world.publishBalls({ballStamped(i)});
  EXPECT_EQ(world.measurementsSince(&cursor).size(), fw::WorldState::kMeasurementsKept);
}

}  // namespace
