// The simulated laser logs: what they say reads back as simulated, and the
// front-end maps a simulated building against its truth.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/laser_simulator.h"
#include "cairn/frontend/mapper.h"
#include "test_util.h"

namespace cairn::frontend {
namespace {

std::string WriteLog(const LaserSimulation& sim, const std::string& name) {
  const std::string path = testing::TempDir() + "/" + name;
  std::ofstream os(path);
  WriteCarmenLog(sim, os);
  return path;
}

// The largest position and heading errors of per-scan poses (the mapper's,
// or dead reckoning) against the truth, both in the first scan's frame.
struct Errors {
  double position = 0, heading = 0;
};
Errors AgainstTruth(const LaserSimulation& sim, const std::vector<SE2>& poses) {
  Errors e;
  for (size_t k = 0; k < sim.truth.size(); ++k) {
    const SE2 truth = sim.truth.front().Between(sim.truth[k]);
    e.position = std::max(e.position, (poses[k].translation() - truth.translation()).norm());
    e.heading = std::max(e.heading, std::abs(NormalizeAngle(poses[k].theta() - truth.theta())));
  }
  return e;
}

// The mapper with its defaults on the simulated log, written as `name`.
MapResult MapSimulated(const LaserSimulation& sim, const std::string& name) {
  return BuildPoseGraph(ReadCarmenLog(WriteLog(sim, name)), MapperOptions{});
}

// Within 0.4 m and 0.05 rad of the truth everywhere: the map was not turned
// or pulled along (the failures these tests keep out were metres off).
void ExpectNearTruth(const LaserSimulation& sim, const MapResult& res, uint64_t seed) {
  const Errors e = AgainstTruth(sim, res.scan_poses);
  EXPECT_LT(e.position, 0.4) << seed;
  EXPECT_LT(e.heading, 0.05) << seed;
}

TEST(LaserSimulator, LogReadsBackAsSimulated) {
  LaserSimulationOptions o;
  o.path_length = 60;
  const LaserSimulation sim = SimulateLaserLog(o);
  ASSERT_GT(sim.truth.size(), 40u);
  ASSERT_EQ(sim.odometry.size(), sim.truth.size());
  const CarmenLog log = ReadCarmenLog(WriteLog(sim, "sim_readback.log"));
  ASSERT_EQ(log.scans.size(), sim.truth.size());
  int hits = 0;
  for (size_t k = 0; k < log.scans.size(); ++k) {
    const LaserScan& s = log.scans[k];
    ASSERT_EQ(s.ranges.size(), 181u);
    EXPECT_NEAR(s.angle_min, -M_PI / 2, 1e-9);
    EXPECT_NEAR(s.angle_increment, M_PI / 180, 1e-9);
    EXPECT_NEAR(s.reference.x(), sim.truth[k].x(), 1e-6);
    EXPECT_NEAR(s.reference.y(), sim.truth[k].y(), 1e-6);
    EXPECT_NEAR(NormalizeAngle(s.reference.theta() - sim.truth[k].theta()), 0, 1e-6);
    if (k > 0) {
      EXPECT_TRUE(s.odometry_measured);
      EXPECT_NEAR(s.odometry_increment.x(), sim.odometry[k].x(), 1e-5) << k;
      EXPECT_NEAR(s.odometry_increment.y(), sim.odometry[k].y(), 1e-5) << k;
      EXPECT_NEAR(NormalizeAngle(s.odometry_increment.theta() - sim.odometry[k].theta()), 0, 1e-5);
    }
    for (float r : s.ranges) {
      EXPECT_GE(r, 0.f);
      hits += r < o.max_range;
    }
  }
  EXPECT_GT(hits, static_cast<int>(log.scans.size()) * 150);  // indoors: most beams hit a wall
}

TEST(LaserSimulator, SeedDecidesTheBuilding) {
  LaserSimulationOptions o;
  o.path_length = 30;
  const LaserSimulation a = SimulateLaserLog(o), b = SimulateLaserLog(o);
  o.seed = 2;
  const LaserSimulation c = SimulateLaserLog(o);
  EXPECT_EQ(a.ranges, b.ranges);
  EXPECT_NE(a.ranges, c.ranges);
  EXPECT_TRUE(a.width != c.width || a.height != c.height);
}

// The odometry is several metres off by the end; the front-end must not be.
TEST(LaserSimulator, MapperFollowsTheTruth) {
  for (uint64_t seed : {1u, 3u}) {
    LaserSimulationOptions o;
    o.seed = seed;
    o.path_length = 100;
    const LaserSimulation sim = SimulateLaserLog(o);
    const MapResult res = MapSimulated(sim, "sim_map.log");
    ASSERT_EQ(res.scan_poses.size(), sim.truth.size());
    EXPECT_GT(AgainstTruth(sim, res.dead_reckoning).position, 0.5) << seed;
    EXPECT_LT(AgainstTruth(sim, res.scan_poses).position, 0.15) << seed;
  }
}

// Every other scan dropped: steps of 1.6 m and up to 40 degrees, into new
// space. The wide search offered poses a quarter turn off or a door along
// (more inliers than the true pose, which sees mostly new walls), whose
// beams crossed walls the local map held; taken, they turned the rest of
// the map (seeds 1 and 3: ATE 7.3 and 19.0 m).
TEST(LaserSimulator, SkippedScansDoNotTurnTheMap) {
  for (uint64_t seed : {1u, 3u}) {
    LaserSimulationOptions o;
    o.seed = seed;
    const LaserSimulation full = SimulateLaserLog(o);
    LaserSimulation sim = full;
    sim.truth.clear(), sim.odometry.clear(), sim.ranges.clear();
    for (size_t k = 0; k < full.truth.size(); k += 2) {
      sim.truth.push_back(full.truth[k]);
      sim.ranges.push_back(full.ranges[k]);
      sim.odometry.push_back(k == 0 ? SE2() : full.odometry[k - 1] * full.odometry[k]);
    }
    const MapResult res = MapSimulated(sim, "sim_skip.log");
    ExpectNearTruth(sim, res, seed);
    EXPECT_GE(res.stats.vetoed, 1u) << seed;
  }
}

// An odometry glitch (heading off by 85 degrees) while the robot turns on
// the spot at a corridor crossing: the crossing turned by a quarter fits
// the scan nearly as well as the true pose, inside the narrow window of
// the glitched prediction. Its beams cross walls the local map holds;
// taken, it turned the rest of the map (seed 5: ATE 6.9 m).
TEST(LaserSimulator, GlitchAtACrossingIsNotMatchedToItsTurnedTwin) {
  LaserSimulationOptions o;
  o.seed = 5;
  LaserSimulation sim = SimulateLaserLog(o);
  ASSERT_GT(sim.odometry.size(), 125u);
  sim.odometry[124] = sim.odometry[124] * SE2(0, 0, -85 * M_PI / 180);
  const MapResult res = MapSimulated(sim, "sim_glitch.log");
  ExpectNearTruth(sim, res, o.seed);
  EXPECT_GE(res.stats.wide_searches, 1u);
}

// Heading drift of 1 degree per metre (seed 2, the largest building): once
// the map has drifted, a corridor's look-alike stretch two metres along
// lies as near the estimate as the true one and fits the last scans as
// well. Its scan, placed there, puts points where the candidate's keyframes
// saw free space and beams through their walls; taken, the loop closure
// pulled the map two metres along (ATE 1.9 m).
TEST(LaserSimulator, ALookAlikeStretchIsNoLoopClosure) {
  LaserSimulationOptions o;
  o.seed = 2;
  LaserSimulation sim = SimulateLaserLog(o);
  for (SE2& step : sim.odometry)
    step = SE2(step.x(), step.y(), step.theta() + M_PI / 180 * step.translation().norm());
  const MapResult res = MapSimulated(sim, "sim_drift.log");
  ExpectNearTruth(sim, res, o.seed);
  EXPECT_GE(res.stats.loop_contradicted, 1u);
}

}  // namespace
}  // namespace cairn::frontend
