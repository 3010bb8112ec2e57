// Front-end units: CARMEN parsing, scan matching on a synthetic room,
// loop-closure verification, the grid's beam update, image writing,
// trajectory errors and the front-end's optimiser.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "cairn/graph/graph_io.h"
#include "test_util.h"
#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/image_io.h"
#include "cairn/frontend/mapper.h"
#include "cairn/frontend/occupancy_grid.h"
#include "cairn/frontend/optimize.h"
#include "cairn/frontend/scan_matcher.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"

namespace cairn::frontend {
namespace {

struct Segment {
  Eigen::Vector2d a, b;
};

// A 10 x 7 m room with a pillar and a nook, so that no pose is ambiguous.
std::vector<Segment> Room() {
  std::vector<Eigen::Vector2d> outline = {{0, 0}, {10, 0}, {10, 4}, {8.5, 4}, {8.5, 7}, {0, 7}};
  std::vector<Segment> walls;
  for (size_t i = 0; i < outline.size(); ++i) walls.push_back({outline[i], outline[(i + 1) % outline.size()]});
  const std::vector<Eigen::Vector2d> pillar = {{3, 2}, {3.6, 2}, {3.6, 2.8}, {3, 2.8}};
  for (size_t i = 0; i < pillar.size(); ++i) walls.push_back({pillar[i], pillar[(i + 1) % pillar.size()]});
  walls.push_back({{6, 5}, {7.5, 6}});
  return walls;
}

// A long, featureless corridor: no place along it differs from another.
std::vector<Segment> Corridor() {
  return {{{-50, 0}, {50, 0}}, {{-50, 2}, {50, 2}}};
}

LaserScan Render(const std::vector<Segment>& walls, const SE2& pose, int beams = 361,
                 double max_range = 30) {
  LaserScan scan;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / (beams - 1);
  for (int i = 0; i < beams; ++i) {
    const double a = pose.theta() + scan.angle_min + i * scan.angle_increment;
    const Eigen::Vector2d o = pose.translation(), d(std::cos(a), std::sin(a));
    double best = max_range;
    for (const Segment& w : walls) {
      const Eigen::Vector2d e = w.b - w.a;
      const double den = d.x() * (-e.y()) - d.y() * (-e.x());
      if (std::abs(den) < 1e-12) continue;
      const Eigen::Vector2d r = w.a - o;
      const double t = (r.x() * (-e.y()) - r.y() * (-e.x())) / den;
      const double u = (d.x() * r.y() - d.y() * r.x()) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    scan.ranges.push_back(static_cast<float>(best));
  }
  return scan;
}

TEST(ScanMatcher, RecoversKnownTransformInSyntheticRoom) {
  const auto room = Room();
  const SE2 a(2.0, 1.5, 0.3), b(2.6, 1.9, 0.45);
  PointCloud map_cloud;
  map_cloud.Append(ScanToCloud(Render(room, a), 0.05, 29.9), a);
  const PointCloud scan_b = ScanToCloud(Render(room, b), 0.05, 29.9);
  const MatchMap coarse(map_cloud, 0.1, 0.25, 0.1), fine(map_cloud, 0.05, 0.3, 0.05);
  const SE2 guess = b * SE2(-0.2, 0.12, 0.08);  // an odometry-sized error
  CorrelativeOptions co;
  const CorrelativeResult cr = CorrelativeMatch(coarse, fine, Downsample(scan_b, 0.1).points, guess, co);
  EXPECT_LT((cr.pose.translation() - b.translation()).norm(), 0.08);
  const IcpResult icp = IcpMatch(fine, scan_b, cr.pose, IcpOptions{});
  ASSERT_TRUE(icp.converged);
  EXPECT_LT((icp.pose.translation() - b.translation()).norm(), 0.01);
  EXPECT_LT(std::abs(NormalizeAngle(icp.pose.theta() - b.theta())), 0.2 * M_PI / 180);
  EXPECT_GT(icp.inlier_fraction, 0.95);
  EXPECT_LT(icp.mean_residual, 0.005);
  // The information is estimated, positive definite and not a constant.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(icp.information);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0);
}

TEST(ScanMatcher, CorridorInformationIsWeakAlongTheAxis) {
  const auto walls = Corridor();
  const SE2 a(0, 1, 0);
  PointCloud map_cloud;
  map_cloud.Append(ScanToCloud(Render(walls, a, 361, 81.9), 0.05, 29.0), a);
  const MatchMap fine(map_cloud, 0.05, 0.3, 0.05);
  IcpResult icp = IcpMatch(fine, ScanToCloud(Render(walls, SE2(0.3, 1, 0), 361, 81.9), 0.05, 29.0),
                           SE2(0.3, 1, 0), IcpOptions{});
  ASSERT_TRUE(icp.converged);
  const Eigen::Matrix3d cov = icp.information.inverse();
  EXPECT_GT(cov(0, 0), 100 * cov(1, 1));  // along x barely known, across well known
}

TEST(LoopClosure, AcceptsTheRightPlaceAndRejectsAWrongCandidate) {
  const auto room = Room();
  const SE2 a(2.0, 1.5, 0.3), b(2.5, 1.8, 0.2);
  PointCloud submap;
  submap.Append(ScanToCloud(Render(room, a), 0.05, 29.9), a);
  const PointCloud query = ScanToCloud(Render(room, b), 0.05, 29.9);
  MapperOptions o;
  SE2 pose;
  Eigen::Matrix3d info;
  ASSERT_TRUE(VerifyLoopClosure(submap, query, b * SE2(0.4, -0.3, 0.1), 1.0,
                                o.loop_angular_window, o, &pose, &info));
  EXPECT_LT((pose.translation() - b.translation()).norm(), 0.02);

  // A scan from another place (the corridor) near the same estimate: the
  // fitness tests must refuse it.
  const PointCloud elsewhere = ScanToCloud(Render(Corridor(), SE2(0, 1, 0)), 0.05, 29.9);
  EXPECT_FALSE(
      VerifyLoopClosure(submap, elsewhere, b, 1.0, o.loop_angular_window, o, &pose, &info));
  // And in a corridor, a short-sighted scan fits anywhere along it: the
  // ambiguity test must refuse to pick a place.
  PointCloud corridor_map;
  corridor_map.Append(ScanToCloud(Render(Corridor(), SE2(0, 1, 0)), 0.05, 29.9), SE2(0, 1, 0));
  const PointCloud short_sighted = ScanToCloud(Render(Corridor(), SE2(0, 1, 0), 361, 8.0), 0.05, 7.9);
  EXPECT_FALSE(VerifyLoopClosure(corridor_map, short_sighted, SE2(0.5, 1, 0), 1.0,
                                 o.loop_angular_window, o, &pose, &info));
}

TEST(OccupancyGrid, SingleBeamClearsThenMarksTheHit) {
  GridOptions go;
  go.resolution = 0.05;
  OccupancyGrid grid({0, 0}, {2, 1}, go);
  grid.AddBeam({0.025, 0.025}, {1.025, 0.025}, true);
  for (int x = 0; x < 20; ++x) {
    EXPECT_TRUE(grid.Known(x, 0));
    EXPECT_FLOAT_EQ(grid.LogOdds(x, 0), static_cast<float>(go.log_odds_miss)) << x;
  }
  EXPECT_FLOAT_EQ(grid.LogOdds(20, 0), static_cast<float>(go.log_odds_hit));
  EXPECT_GT(grid.Probability(20, 0), 0.65);
  EXPECT_FALSE(grid.Known(21, 0));
  EXPECT_FALSE(grid.Known(5, 1));
  // A no-return beam only clears, the end cell included.
  grid.AddBeam({0.025, 0.525}, {1.025, 0.525}, false);
  for (int x = 0; x <= 20; ++x) EXPECT_LT(grid.LogOdds(x, 10), 0) << x;
  // One miss is not yet "free" by map_server's thresholds; a few are.
  for (int k = 0; k < 4; ++k) grid.AddBeam({0.025, 0.025}, {1.025, 0.025}, true);
  const Image img = grid.ToTrinary();
  EXPECT_EQ(img.pixels[static_cast<size_t>(grid.height() - 1) * grid.width() + 20], 0);  // occupied
  EXPECT_EQ(img.pixels[static_cast<size_t>(grid.height() - 1) * grid.width() + 5], 254);  // free
  EXPECT_EQ(img.pixels[0], 205);                                                        // unknown
}

TEST(OccupancyGrid, AWallJoinsTwoHitsWithoutTheirEnds) {
  GridOptions go;
  go.resolution = 0.1;
  OccupancyGrid grid({0, 0}, {2, 2}, go);
  grid.AddWall({0.05, 0.05}, {0.55, 0.05});
  for (int x = 1; x <= 4; ++x) EXPECT_FLOAT_EQ(grid.LogOdds(x, 0), static_cast<float>(go.log_odds_hit)) << x;
  EXPECT_FALSE(grid.Known(0, 0));
  EXPECT_FALSE(grid.Known(5, 0));
  grid.AddWall({1.05, 1.05}, {1.06, 1.07});  // one cell: nothing between
  EXPECT_FALSE(grid.Known(10, 10));
}

// Cells of the grid's trinary image along a segment parallel to y that are
// not occupied (0), nor their neighbours either side across it.
int GapsAlong(const OccupancyGrid& grid, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Image img = grid.ToTrinary();
  int gaps = 0;
  const int steps = static_cast<int>((b - a).norm() / grid.resolution());
  for (int k = 0; k <= steps; ++k) {
    int cx, cy;
    grid.Cell(a + (b - a) * (static_cast<double>(k) / steps), &cx, &cy);
    bool occupied = false;
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = cx + dx;
      if (x >= 0 && x < grid.width())
        occupied |= img.pixels[static_cast<size_t>(grid.height() - 1 - cy) * grid.width() + x] == 0;
    }
    gaps += !occupied;
  }
  return gaps;
}

// One scan of 1-degree beams at a wall 8 m off: 14 cm between hits, three
// 5 cm cells. The grid joins them; a doorway-sized gap it leaves.
TEST(OccupancyGrid, BeamsSpreadAtRangeLeaveNoGapsInAWall) {
  CarmenLog log;
  std::vector<Segment> walls = {{{8.01, -3}, {8.01, 3}}, {{8.01, 3.8}, {8.01, 6}}};
  LaserScan s = Render(walls, SE2(), 181, 30);
  log.scans = {s};
  GridOptions go;
  go.resolution = 0.05;
  const OccupancyGrid joined = BuildOccupancyGrid(log, {SE2()}, 30, go);
  EXPECT_EQ(GapsAlong(joined, {8.01, -2.9}, {8.01, 2.9}), 0);
  EXPECT_GT(GapsAlong(joined, {8.01, 3.1}, {8.01, 3.7}), 8);  // the 0.8 m doorway stays open
  go.max_wall_gap = 0;
  const OccupancyGrid beams_only = BuildOccupancyGrid(log, {SE2()}, 30, go);
  EXPECT_GT(GapsAlong(beams_only, {8.01, -2.9}, {8.01, 2.9}), 40);
}

TEST(OccupancyGrid, NoReturnBeamsClearAShortWayOrNotAtAll) {
  CarmenLog log;
  LaserScan s = Render({}, SE2(), 181, 30);  // nothing in sight: every beam at maximum range
  log.scans = {s};
  GridOptions go;
  go.resolution = 0.1;
  const OccupancyGrid grid = BuildOccupancyGrid(log, {SE2()}, 30, go);
  int cx, cy;
  ASSERT_TRUE(grid.Cell({go.max_clear_range - 0.25, 0}, &cx, &cy));
  EXPECT_TRUE(grid.Known(cx, cy));
  EXPECT_LT(grid.LogOdds(cx, cy), 0);
  EXPECT_FALSE(grid.Cell({go.max_clear_range + 1.5, 0}, &cx, &cy) && grid.Known(cx, cy));
  go.max_clear_range = 0;
  const OccupancyGrid untouched = BuildOccupancyGrid(log, {SE2()}, 30, go);
  for (int y = 0; y < untouched.height(); ++y)
    for (int x = 0; x < untouched.width(); ++x) EXPECT_FALSE(untouched.Known(x, y));
}

TEST(ImageIo, PngHasSignatureChunksAndCrc) {
  Image img{3, 2, 1, {0, 128, 255, 10, 20, 30}};
  std::ostringstream os;
  WritePng(img, os);
  const std::string s = os.str();
  ASSERT_GT(s.size(), 8u + 25u + 12u);
  EXPECT_EQ(s.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(s.substr(12, 4), "IHDR");
  EXPECT_EQ(s.substr(s.size() - 8, 4), "IEND");
  // IEND's CRC is a constant of the format.
  EXPECT_EQ(s.substr(s.size() - 4), std::string("\xae\x42\x60\x82", 4));
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::path(cairn::testing::TempDir()) / name;
  std::ofstream(path) << text;
  return path.string();
}

TEST(CarmenLog, RecoversRawOdometryAndReferencePoses) {
  std::string beams;
  for (int i = 0; i < 180; ++i) beams += " 2.5";
  const std::string path = WriteTemp("cairn_test.log",
      "# comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n"
      "ODOM 0 0 0 0 0 0 1.0 h 1.0\n"
      "FLASER 180" + beams + " 1 2 0.5 1 2 0.5 10.5 h 10.5\n"
      "ODOM 1 2 0.5 0 0 0 0 h 0\n"
      "ODOM 1.5 2 0.6 0 0 0 11.0 h 11.0\n"
      "NEFF 10\n"
      "FLASER 180" + beams + " 1.4 2.1 0.55 1.4 2.1 0.55 11.5 h 11.5\n");
  const CarmenLog log = ReadCarmenLog(path);
  ASSERT_EQ(log.scans.size(), 2u);
  EXPECT_DOUBLE_EQ(log.scans[1].timestamp, 11.5);
  EXPECT_NEAR(log.scans[1].reference.x(), 1.4, 1e-12);
  const SE2 expected = SE2(1, 2, 0.5).Between(SE2(1.5, 2, 0.6));
  EXPECT_NEAR(log.scans[1].odometry_increment.x(), expected.x(), 1e-12);
  EXPECT_NEAR(log.scans[1].odometry_increment.y(), expected.y(), 1e-12);
  EXPECT_NEAR(log.scans[1].odometry_increment.theta(), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(log.max_reading, 2.5);
  EXPECT_NEAR(log.scans[0].angle_increment, M_PI / 180, 1e-12);
}

TEST(CarmenLog, ReadsRobotLaserWithItsOwnGeometryAndOffset) {
  // ROBOTLASER1 type start fov res maxrange accuracy remission n r.. nrem
  // laser(x y th) robot(x y th) tv rv fsd ssd turn timestamp host logger
  const std::string path = WriteTemp("cairn_robotlaser.log",
      "ROBOTLASER1 0 -1.5 3.0 0.75 50 0.01 0 5 1 2 3 4 5 0 1.2 2 0.1 1 2 0.1 0 0 0 0 0 7.25 h 7.25\n");
  const CarmenLog log = ReadCarmenLog(path);
  ASSERT_EQ(log.scans.size(), 1u);
  const LaserScan& s = log.scans[0];
  EXPECT_EQ(s.ranges.size(), 5u);
  EXPECT_DOUBLE_EQ(s.angle_min, -1.5);
  EXPECT_DOUBLE_EQ(s.angle_increment, 0.75);
  EXPECT_NEAR(s.reference.x(), 1, 1e-12);
  // The laser's pose in the robot's frame (20 cm apart in the world).
  const SE2 offset = SE2(1, 2, 0.1).Between(SE2(1.2, 2, 0.1));
  EXPECT_NEAR(s.laser_offset.x(), offset.x(), 1e-12);
  EXPECT_NEAR(s.laser_offset.y(), offset.y(), 1e-12);
  EXPECT_NEAR(s.laser_offset.theta(), 0, 1e-12);
  EXPECT_DOUBLE_EQ(s.timestamp, 7.25);
  EXPECT_DOUBLE_EQ(s.max_range, 50);
  EXPECT_DOUBLE_EQ(log.declared_max_range, 50);
}

// A FLASER line with n beams of 2.5 m but the first (1 m) and last (3 m).
std::string Flaser(int n) {
  std::string line = "FLASER " + std::to_string(n) + " 1";
  for (int i = 1; i + 1 < n; ++i) line += " 2.5";
  return line + " 3 0 0 0 0 0 0 1.5 h 1.5\n";
}

TEST(CarmenLog, FlaserGeometryFromParamLines) {
  struct Case {
    std::string params;
    int beams;
    double angle_min, increment;
  };
  const double deg = M_PI / 180;
  for (const Case& c : std::vector<Case>{
           {"", 181, -90 * deg, 1 * deg},  // no PARAM: 180 degrees
           {"", 180, -90 * deg, 1 * deg},
           {"PARAM laser_front_laser_fov 90\nPARAM laser_front_laser_resolution 1\n", 91, -45 * deg, deg},
           {"PARAM laser_front_laser_fov 270\nPARAM laser_front_laser_resolution 0.25\n", 1081,
            -135 * deg, 0.25 * deg},
           // Radians in older logs; the span the beams cover, not the rounded value.
           {"PARAM laser_front_laser_fov 3.14159\nPARAM laser_front_laser_resolution 0.5\n", 361,
            -90 * deg, 0.5 * deg},
           // A resolution the beam count does not fit: the field of view split by the count.
           {"PARAM laser_front_laser_fov 100\nPARAM laser_front_laser_resolution 1\n", 51, -50 * deg,
            2 * deg},
           {"PARAM laser_front_laser_resolution 0.5\n", 360, -90 * deg, 0.5 * deg}}) {
    const CarmenLog log = ReadCarmenLog(WriteTemp("cairn_param.log", c.params + Flaser(c.beams)));
    ASSERT_EQ(log.scans.size(), 1u);
    EXPECT_NEAR(log.scans[0].angle_min, c.angle_min, 1e-12) << c.params << c.beams;
    EXPECT_NEAR(log.scans[0].angle_increment, c.increment, 1e-12) << c.params << c.beams;
    EXPECT_EQ(log.scans[0].max_range, 0);
  }
}

TEST(CarmenLog, FlippedLaserAndDeclaredMaximumRange) {
  const CarmenLog log = ReadCarmenLog(WriteTemp(
      "cairn_flipped.log", "PARAM laser_front_laser_flipped 1 h 0\nPARAM robot_front_laser_max 40 h 0\n" +
                               Flaser(181) + "PARAM laser_front_laser_flipped 0 h 0\n" + Flaser(181)));
  ASSERT_EQ(log.scans.size(), 2u);
  EXPECT_EQ(log.scans[0].ranges.front(), 3.0f);
  EXPECT_EQ(log.scans[0].ranges.back(), 1.0f);
  EXPECT_EQ(log.scans[1].ranges.front(), 1.0f);
  EXPECT_DOUBLE_EQ(log.scans[1].max_range, 40);
  EXPECT_DOUBLE_EQ(log.declared_max_range, 40);
  EXPECT_DOUBLE_EQ(log.max_reading, 3);
}

TEST(CarmenLog, BadLaserParameterNamesItsLine) {
  for (const char* bad : {"PARAM laser_front_laser_fov wide\n", "PARAM laser_front_laser_fov -10\n",
                          "PARAM laser_front_laser_resolution 0\n", "PARAM robot_front_laser_max nan\n"}) {
    const std::string path = WriteTemp("cairn_badparam.log", std::string("# log\n") + bad + Flaser(181));
    try {
      ReadCarmenLog(path);
      ADD_FAILURE() << "no error for " << bad;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.line(), 2u) << e.what();
    }
  }
  // Parameters the front-end does not use say what they like.
  EXPECT_EQ(ReadCarmenLog(WriteTemp("cairn_okparam.log", "PARAM robot_use_laser on h 0\n" + Flaser(181)))
                .scans.size(),
            1u);
}

TEST(CarmenLog, MalformedLineNamesFileAndLine) {
  const std::string path = WriteTemp("cairn_bad.log", "ODOM 0 0 0 0 0 0 1 h 1\nFLASER 3 1.0 x 2.0 0 0 0 0 0 0 1 h 1\n");
  try {
    ReadCarmenLog(path);
    FAIL() << "expected a ParseError";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_NE(std::string(e.what()).find(path + ":2:"), std::string::npos) << e.what();
  }
  const std::string truncated = WriteTemp("cairn_short.log", "FLASER 180 1 2 3\n");
  EXPECT_THROW(ReadCarmenLog(truncated), ParseError);
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(MapTool, MalformedLogFailsWithFileLineAndWritesNothing) {
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_map_bad";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string log = (dir / "bad.log").string();
  std::ofstream(log) << "ODOM 0 0 0 0 0 0 1 h 1\nFLASER 3 1.0 x 2.0 0 0 0 0 0 0 1 h 1\n";
  const std::string cmd = std::string(CAIRN_TOOL) + " map " + log + " -o " + (dir / "out").string() +
                          " 2> " + (dir / "err").string();
  EXPECT_NE(std::system(cmd.c_str()), 0);
  EXPECT_NE(ReadAll((dir / "err").string()).find(log + ":2: "), std::string::npos);
  size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.path().filename() != "err";
  EXPECT_EQ(files, 1u);  // only the log itself
}

TEST(Trajectory, RigidCopyHasNoErrorAndNoiseIsMeasured) {
  Trajectory ref, est, noisy;
  const SE2 offset(5, -3, 1.0);
  for (int i = 0; i < 100; ++i) {
    const SE2 p(0.1 * i, std::sin(0.1 * i), 0.05 * i);
    ref.Add(i * 0.5, p);
    est.Add(i * 0.5, offset * p);
    noisy.Add(i * 0.5, SE2(p.x() + (i % 2 ? 0.1 : -0.1), p.y(), p.theta()));
  }
  TrajectoryErrors e = EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.matched, 100u);
  EXPECT_NEAR(e.ate_rmse, 0, 1e-9);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);
  e = EvaluateTrajectory(noisy, ref);
  EXPECT_NEAR(e.ate_rmse, 0.1, 0.01);
  EXPECT_GT(e.rpe_trans_rmse, 0.05);
}

TEST(Trajectory, RepeatedStampsPairOnlyWhenUnambiguous) {
  Trajectory ref, est;
  for (int i = 0; i < 6; ++i) ref.Add(i < 3 ? 100.0 : 200.0, SE2(i, 0, 0));
  // All of the first group, two of the three of the second.
  for (int i : {0, 1, 2, 3, 5}) est.Add(i < 3 ? 100.0 : 200.0, SE2(i, 0, 0));
  const auto pairs = Associate(est, ref);
  ASSERT_EQ(pairs.size(), 3u);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(pairs[k], std::make_pair(k, k));
}

// A square loop with a biased odometry and one true loop closure, plus one
// false closure the robust loss must shrug off.
PoseGraph SquareLoop() {
  PoseGraph g(2);
  SE2 x;
  const int n = 16;
  std::vector<SE2> steps;
  for (int i = 0; i < n; ++i) {
    const SE2 step = (i % 4 == 3) ? SE2(1, 0, M_PI / 2) : SE2(1, 0, 0);
    steps.emplace_back(step.x() * 1.03, 0.02, step.theta() + 0.03);
  }
  for (int i = 0; i <= n; ++i) {
    g.AddVertex(i, x, i == 0);
    if (i < n) x = x * steps[i];
  }
  for (int i = 0; i < n; ++i) {
    Edge e;
    e.from = i;
    e.to = i + 1;
    e.z = ToParams(steps[i]);
    e.information.SetTopLeft(Eigen::Vector3d(100, 100, 400).asDiagonal());
    g.AddEdge(e);
  }
  Edge lc;
  lc.kind = EdgeKind::kLoopClosure;
  lc.from = 0;
  lc.to = n;
  lc.z = ToParams(SE2(0, 0, 0));
  lc.information.SetTopLeft(Eigen::Vector3d(1000, 1000, 4000).asDiagonal());
  g.AddEdge(lc);
  lc.from = 2;
  lc.to = 10;
  lc.z = ToParams(SE2(3, 3, 1));  // wrong
  g.AddEdge(lc);
  return g;
}

// A drive through the room, as a corrected CARMEN log: ODOM lines at the
// true poses (the chain restarts at each scan's pose), FLASER lines with
// stamps repeated in pairs, as a log with too few digits has them.
// With `glitch`, the odometry of step `glitch_at` is that much off.
std::string RoomDriveLog(int scans, std::vector<SE2>* truth, int glitch_at = -1,
                         const SE2& glitch = SE2()) {
  std::ostringstream log;
  log.precision(17);
  for (int i = 0; i < scans; ++i) {
    const SE2 pose(1.5 + 0.12 * i, 1.2 + 0.05 * i, 0.2 + 0.01 * i);
    truth->push_back(pose);
    const std::string stamp = std::to_string(100 + i / 2) + ".5";
    const SE2 odom = i == glitch_at ? (*truth)[i - 1] * (*truth)[i - 1].Between(pose) * glitch : pose;
    log << "ODOM " << odom.x() << ' ' << odom.y() << ' ' << odom.theta() << " 0 0 0 " << stamp << " h "
        << stamp << "\n";
    const LaserScan s = Render(Room(), pose);
    log << "FLASER " << s.ranges.size();
    for (float r : s.ranges) log << ' ' << r;
    for (int k = 0; k < 2; ++k) log << ' ' << pose.x() << ' ' << pose.y() << ' ' << pose.theta();
    log << ' ' << stamp << " h " << stamp << "\n";
  }
  return log.str();
}

TEST(Mapper, ReportsProgressAsItWalksTheLog) {
  std::vector<SE2> truth;
  const CarmenLog log = ReadCarmenLog(WriteTemp("cairn_progress.log", RoomDriveLog(12, &truth)));
  MapperOptions o;
  o.progress_interval_s = 0;  // a line after every scan
  std::ostringstream progress;
  BuildPoseGraph(log, o, &progress);
  for (int i = 1; i <= 12; ++i)
    EXPECT_NE(progress.str().find("map: scan " + std::to_string(i) + " of 12, "), std::string::npos)
        << progress.str();
  EXPECT_NE(progress.str().find(" keyframes, 0 loop closures, 0 recoveries, 0 fell back to odometry, "),
            std::string::npos)
      << progress.str();
  o.progress_interval_s = 1e9;
  std::ostringstream none;
  BuildPoseGraph(log, o, &none);
  EXPECT_EQ(none.str(), "");
}

// The summary a tool prints after the progress lines must keep its digits:
// `cairn map` printed a learned odometry scale of 1.01957 as "1".
TEST(Mapper, ProgressLeavesTheStreamAsItFoundIt) {
  std::vector<SE2> truth;
  const CarmenLog log = ReadCarmenLog(WriteTemp("cairn_progress_fmt.log", RoomDriveLog(6, &truth)));
  MapperOptions o;
  o.progress_interval_s = 0;
  std::ostringstream progress;
  const auto flags = progress.flags();
  BuildPoseGraph(log, o, &progress);
  EXPECT_NE(progress.str().find("map: scan 6 of 6, "), std::string::npos);
  EXPECT_EQ(progress.precision(), 6);
  EXPECT_EQ(progress.flags(), flags);
  progress.str("");
  progress << 1.01957;
  EXPECT_EQ(progress.str(), "1.01957");
}

// One odometry step 80 degrees and 40 cm off: the match at the tracking
// window's edge is judged poor, the wide search finds the scan's pose, and
// the rest of the drive is tracked in the right frame.
TEST(Mapper, RecoversFromAnOdometryGlitch) {
  for (const double heading : {80.0, -65.0}) {
    std::vector<SE2> truth;
    const SE2 glitch(0.3, -0.25, heading * M_PI / 180);
    const CarmenLog log =
        ReadCarmenLog(WriteTemp("cairn_glitch.log", RoomDriveLog(30, &truth, 12, glitch)));
    const MapResult res = BuildPoseGraph(log, MapperOptions{});
    EXPECT_GE(res.stats.recoveries, 1u);
    EXPECT_GE(res.stats.wide_searches, res.stats.recoveries);
    EXPECT_EQ(res.stats.tracking_failures, 0u);
    const SE2 last_truth = truth.front().Between(truth.back());
    const SE2 last_dr = res.dead_reckoning.back();
    EXPECT_GT((last_dr.translation() - last_truth.translation()).norm(), 1.0);  // a real glitch
    const SE2& last = res.scan_poses.back();
    EXPECT_LT((last.translation() - last_truth.translation()).norm(), 0.05) << heading;
    EXPECT_LT(std::abs(NormalizeAngle(last.theta() - last_truth.theta())), 0.02) << heading;
  }
}

// Odometry whose heading is off by up to 35 degrees at every step, seeds
// 1-3: more than the usual +-20 degree window. The first steps beyond it
// go to the wide search; then the window widens to what the odometry's
// errors have been, so that most such steps are matched in the narrow
// search, and the drive is tracked to the end.
TEST(Mapper, WindowFollowsPoorOdometry) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::ostringstream text;
    text.precision(17);
    std::vector<SE2> truth;
    int beyond = 0;
    for (int i = 0; i < 60; ++i) {
      const SE2 pose(1.5 + 0.08 * i, 1.2 + 0.03 * i, 0.2 + 0.01 * i);
      const double err = 35 * u(rng) * M_PI / 180;
      beyond += i > 0 && std::abs(err) > 20 * M_PI / 180;
      const SE2 odom = i == 0 ? pose : pose * SE2(0.03 * u(rng), 0.03 * u(rng), err);
      truth.push_back(pose);
      const std::string stamp = std::to_string(100 + i) + ".5";
      text << "ODOM " << odom.x() << ' ' << odom.y() << ' ' << odom.theta() << " 0 0 0 " << stamp
           << " h " << stamp << "\n";
      const LaserScan s = Render(Room(), pose);
      text << "FLASER " << s.ranges.size();
      for (float r : s.ranges) text << ' ' << r;
      for (int k = 0; k < 2; ++k) text << ' ' << pose.x() << ' ' << pose.y() << ' ' << pose.theta();
      text << ' ' << stamp << " h " << stamp << "\n";
    }
    const MapResult res = BuildPoseGraph(ReadCarmenLog(WriteTemp("cairn_poor_odom.log", text.str())),
                                         MapperOptions{});
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_LT(res.stats.wide_searches, static_cast<size_t>(beyond));
    for (size_t i = 0; i < truth.size(); ++i) {
      const SE2 rel = truth[0].Between(truth[i]);
      ASSERT_LT((res.scan_poses[i].translation() - rel.translation()).norm(), 0.05) << "scan " << i;
      ASSERT_LT(std::abs(NormalizeAngle(res.scan_poses[i].theta() - rel.theta())), 0.02) << "scan " << i;
    }
  }
}

TEST(MapTool, WritesKeyframesByScanIndex) {
  std::vector<SE2> truth;
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_map_kf";
  std::filesystem::create_directories(dir);
  const std::string log = WriteTemp("cairn_map_kf/drive.log", RoomDriveLog(30, &truth));
  const std::string prefix = (dir / "out").string();
  const std::string cmd = std::string(CAIRN_TOOL) + " map " + log + " -o " + prefix + " --quiet 2> " +
                          prefix + ".err";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << ReadAll(prefix + ".err");
  std::istringstream csv(ReadAll(prefix + "_keyframes.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "keyframe,scan,timestamp,x,y,theta");
  long expected_keyframe = 0, last_scan = -1;
  while (std::getline(csv, line)) {
    long keyframe = 0, scan = 0;
    char stamp[32];
    double x = 0, y = 0, theta = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%ld,%ld,%31[^,],%lf,%lf,%lf", &keyframe, &scan, stamp, &x, &y,
                          &theta),
              6)
        << line;
    EXPECT_EQ(keyframe, expected_keyframe++);
    EXPECT_GT(scan, last_scan);
    ASSERT_LT(scan, 30);
    last_scan = scan;
    EXPECT_EQ(std::string(stamp), std::to_string(100 + scan / 2) + ".5");
    // In the first keyframe's frame, which is the first scan's.
    const SE2 rel = truth[0].Between(truth[static_cast<size_t>(scan)]);
    EXPECT_NEAR(x, rel.x(), 0.03) << line;
    EXPECT_NEAR(y, rel.y(), 0.03) << line;
    EXPECT_NEAR(theta, rel.theta(), 0.01) << line;
  }
  EXPECT_GE(expected_keyframe, 5);
  // In the log's frame the first keyframe is where the log puts the first scan.
  const std::string in_log = std::string(CAIRN_TOOL) + " map " + log + " -o " + prefix +
                             "_log --frame log --quiet 2> " + prefix + ".err";
  ASSERT_EQ(std::system(in_log.c_str()), 0) << ReadAll(prefix + ".err");
  std::istringstream csv_log(ReadAll(prefix + "_log_keyframes.csv"));
  std::getline(csv_log, line);
  std::getline(csv_log, line);
  double x = 0, y = 0, theta = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "0,0,%*[^,],%lf,%lf,%lf", &x, &y, &theta), 3) << line;
  EXPECT_DOUBLE_EQ(x, truth[0].x());
  EXPECT_DOUBLE_EQ(y, truth[0].y());
  EXPECT_NEAR(theta, truth[0].theta(), 1e-15);
}

TEST(Optimize, BothSolversCloseTheLoopDespiteAFalseClosure) {
  for (SolverKind solver : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
    PoseGraph g = SquareLoop();
    OptimizeOptions o;
    o.solver = solver;
    const OptimizeSummary s = OptimizeGraph(g, o);
    EXPECT_LT(s.final_chi2, s.initial_chi2) << ToString(solver);
    const SE2 end = ToSE2(g.vertex(16).x);
    EXPECT_LT(end.translation().norm(), 0.1) << ToString(solver);
  }
}

}  // namespace
}  // namespace cairn::frontend
