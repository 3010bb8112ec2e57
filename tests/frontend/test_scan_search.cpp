// The correlative search's branch and bound (frontend/scan_matcher.h): the
// pyramid bounds what it pools, and the search finds exactly the pose and
// runner-up an exhaustive search finds, on random rooms and seeds, narrow
// windows and every heading.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cairn/frontend/scan_matcher.h"

namespace cairn::frontend {
namespace {

struct Segment {
  Eigen::Vector2d a, b;
};

// A room of random size with random boxes and free-standing walls.
std::vector<Segment> RandomRoom(std::mt19937& rng) {
  std::uniform_real_distribution<double> w(6, 14), u(0, 1);
  const double W = w(rng), H = w(rng);
  std::vector<Segment> s = {{{0, 0}, {W, 0}}, {{W, 0}, {W, H}}, {{W, H}, {0, H}}, {{0, H}, {0, 0}}};
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector2d c(1 + u(rng) * (W - 2), 1 + u(rng) * (H - 2));
    const double a = u(rng) * M_PI, len = 0.5 + 1.5 * u(rng);
    const Eigen::Vector2d d(std::cos(a) * len / 2, std::sin(a) * len / 2);
    s.push_back({c - d, c + d});
  }
  return s;
}

// Endpoints of a 1-degree scan from `pose`, in the robot frame.
PointCloud Scan(const std::vector<Segment>& walls, const SE2& pose) {
  LaserScan scan;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 180;
  for (int i = 0; i <= 180; ++i) {
    const double a = pose.theta() + scan.angle_min + i * scan.angle_increment;
    const Eigen::Vector2d o = pose.translation(), d(std::cos(a), std::sin(a));
    double best = 30;
    for (const Segment& sg : walls) {
      const Eigen::Vector2d e = sg.b - sg.a, r = sg.a - o;
      const double den = -d.x() * e.y() + d.y() * e.x();
      if (std::abs(den) < 1e-12) continue;
      const double t = (-r.x() * e.y() + r.y() * e.x()) / den, v = (d.x() * r.y() - d.y() * r.x()) / den;
      if (t > 0 && v >= 0 && v <= 1) best = std::min(best, t);
    }
    scan.ranges.push_back(static_cast<float>(best));
  }
  return ScanToCloud(scan, 0.05, 29.9);
}

struct Scored {
  double score = -1, theta = 0;
  Eigen::Vector2d t;
};

// What CorrelativeMatch computed before branch and bound: every coarse pose
// scored, then the same local search on the fine map.
std::pair<CorrelativeResult, double> Exhaustive(const MatchMap& coarse, const MatchMap& fine,
                                                const std::vector<Eigen::Vector2d>& scan,
                                                const SE2& guess, const CorrelativeOptions& o) {
  auto search = [&](const MatchMap& m, const std::vector<double>& angles, const Eigen::Vector2d& c,
                    int n, std::vector<Scored>* all) {
    Scored best;
    const double res = m.resolution();
    for (double th : angles)
      for (int dy = -n; dy <= n; ++dy)
        for (int dx = -n; dx <= n; ++dx) {
          double sum = 0;
          for (const auto& p : scan) {
            const double qx = std::cos(th) * p.x() - std::sin(th) * p.y() + c.x() - m.origin().x();
            const double qy = std::sin(th) * p.x() + std::cos(th) * p.y() + c.y() - m.origin().y();
            sum += m.LikelihoodAtCell(static_cast<int>(std::floor(qx / res)) + dx,
                                      static_cast<int>(std::floor(qy / res)) + dy);
          }
          const Eigen::Vector2d t = c + Eigen::Vector2d(dx * res, dy * res);
          const double dl = (t - guess.translation()).norm() / o.linear_window;
          const double da = NormalizeAngle(th - guess.theta()) / o.angular_window;
          const double score = sum * (1.0 / scan.size()) * (1 - o.distance_penalty * std::min(1.0, dl * dl)) *
                               (1 - o.distance_penalty * std::min(1.0, da * da));
          if (score > best.score) best = {score, th, t};
          if (all) all->push_back({score, th, t});
        }
    return best;
  };
  std::vector<double> angles;
  const int na = static_cast<int>(std::ceil(o.angular_window / (2 * o.angular_step)));
  for (int k = -na; k <= na; ++k) angles.push_back(guess.theta() + k * 2 * o.angular_step);
  std::vector<Scored> all;
  const Scored best = search(coarse, angles, guess.translation(),
                             static_cast<int>(std::ceil(o.linear_window / coarse.resolution())), &all);
  double runner = 0;
  for (const Scored& s : all)
    if ((s.t - best.t).norm() > o.runner_up_distance ||
        (o.runner_up_angle > 0 && std::abs(NormalizeAngle(s.theta - best.theta)) > o.runner_up_angle))
      runner = std::max(runner, s.score);
  angles.clear();
  for (int k = -2; k <= 2; ++k) angles.push_back(best.theta + k * 0.5 * o.angular_step);
  const Scored f = search(fine, angles, best.t,
                          static_cast<int>(std::ceil(coarse.resolution() / fine.resolution())), nullptr);
  return {{SE2(f.t.x(), f.t.y(), f.theta), f.score, runner / best.score}, best.score};
}

TEST(BranchAndBound, PyramidBoundsItsSquares) {
  std::mt19937 rng(3);
  const auto room = RandomRoom(rng);
  PointCloud world;
  world.Append(Scan(room, SE2(3, 3, 0.4)), SE2(3, 3, 0.4));
  const MatchMap map(world, 0.1, 0.25, 0.1);
  map.BuildPyramid(4);
  ASSERT_EQ(map.pyramid_levels(), 4);
  std::uniform_int_distribution<int> cell(-20, 180);
  for (int k = 0; k < 2000; ++k) {
    const int x = cell(rng), y = cell(rng), l = 1 + k % 4;
    float m = 0;
    for (int dy = 0; dy < (1 << l); ++dy)
      for (int dx = 0; dx < (1 << l); ++dx) m = std::max(m, map.LikelihoodAtCell(x + dx, y + dy));
    // Exact inside the grid; from beyond its lower edges, a bound.
    if (x >= 0 && y >= 0)
      ASSERT_EQ(map.PooledAtCell(l, x, y), m) << x << " " << y << " level " << l;
    else
      ASSERT_GE(map.PooledAtCell(l, x, y), m) << x << " " << y << " level " << l;
  }
}

// Seeds 1-6, a narrow tracking window and a wide one over every heading:
// the same pose as the exhaustive search to the bit, the same runner-up
// ratio whenever it is above the floor.
TEST(BranchAndBound, FindsWhatTheExhaustiveSearchFinds) {
  for (int seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    const auto room = RandomRoom(rng);
    const SE2 a(3 + u(rng), 3 + u(rng), u(rng) * M_PI);
    const SE2 b = a * SE2(0.4 + 0.2 * u(rng), 0.2 * u(rng), 0.3 * u(rng));
    PointCloud world;
    world.Append(Scan(room, a), a);
    const MatchMap coarse(world, 0.1, 0.25, 0.1), fine(world, 0.05, 0.3, 0.05);
    const std::vector<Eigen::Vector2d> pts = Downsample(Scan(room, b), 0.1).points;
    for (int wide = 0; wide <= 1; ++wide) {
      CorrelativeOptions o;
      o.linear_window = wide ? 1.5 : 0.5;
      o.angular_window = wide ? M_PI : 0.35;
      o.runner_up_distance = 0.5;
      o.runner_up_angle = wide ? 0.35 : 0;
      const SE2 guess = b * SE2(0.3 * u(rng), 0.3 * u(rng), wide ? 1.5 * u(rng) : 0.2 * u(rng));
      const CorrelativeResult got = CorrelativeMatch(coarse, fine, pts, guess, o);
      const auto [want, coarse_score] = Exhaustive(coarse, fine, pts, guess, o);
      SCOPED_TRACE("seed " + std::to_string(seed) + (wide ? " wide" : " narrow"));
      EXPECT_EQ(got.pose.x(), want.pose.x());
      EXPECT_EQ(got.pose.y(), want.pose.y());
      EXPECT_EQ(got.pose.theta(), want.pose.theta());
      EXPECT_EQ(got.score, want.score);
      if (want.runner_up_ratio >= o.runner_up_floor)
        EXPECT_NEAR(got.runner_up_ratio, want.runner_up_ratio, 1e-12);
      else
        EXPECT_LT(got.runner_up_ratio, o.runner_up_floor);
      // And it found the scan's true pose.
      EXPECT_LT((got.pose.translation() - b.translation()).norm(), 0.1);
    }
  }
}

TEST(ArcMisfit, WhatAWheeledBaseDoesFitsAndItsTwinsDoNot) {
  const SE2 from(2, 1, 0.5);
  // Straight on, along an arc, a turn on the spot.
  EXPECT_EQ(ArcMisfit(from, from * SE2(1, 0, 0)), 0);
  EXPECT_NEAR(ArcMisfit(from, from * SE2(std::cos(0.3), std::sin(0.3), 0.6)), 0, 1e-12);
  EXPECT_EQ(ArcMisfit(from, from * SE2(0.02, 0, 1.2)), 0);
  // Backwards, straight or along an arc: possible, seldom.
  EXPECT_NEAR(ArcMisfit(from, from * SE2(-0.8, 0, 0)), 0.5, 1e-12);
  EXPECT_NEAR(ArcMisfit(from, from * SE2(-std::cos(0.3), -std::sin(0.3), 0.6)), 0.5, 1e-12);
  // A half turn, on the spot or while going straight: what a symmetric
  // place's twin looks like.
  EXPECT_EQ(ArcMisfit(from, from * SE2(0, 0, M_PI)), 1);
  EXPECT_EQ(ArcMisfit(from, from * SE2(1, 0, M_PI)), 1);
  // A quarter turn while going straight, and a straight way with a sideways
  // heading: the chord leaves 45 and 90 degrees off half the turn.
  EXPECT_GT(ArcMisfit(from, from * SE2(1, 0, M_PI / 2)), 0.7);
  EXPECT_EQ(ArcMisfit(from, from * SE2(0, 1, 0)), 1);
  // Short moves say nothing of the way.
  EXPECT_EQ(ArcMisfit(from, from * SE2(0, 0.08, 0)), 0);
}

// A bare rectangular room is the same turned half round about its centre:
// a full view of it matches the true pose and its twin equally. From the
// pose a scan ago, only the true one is a move a wheeled base makes.
TEST(CorrelativeMatch, TheWayTheRobotWentTellsAPlaceFromItsTwin) {
  const double W = 8, H = 5;
  const std::vector<Segment> room = {{{0, 0}, {W, 0}}, {{W, 0}, {W, H}}, {{W, H}, {0, H}}, {{0, H}, {0, 0}}};
  const SE2 a(3.2, 2.7, 0.2);
  PointCloud world;
  for (int k = 0; k < 4; ++k) {
    const SE2 view = a * SE2(0, 0, k * M_PI / 2);
    world.Append(Scan(room, view), view);
  }
  const MatchMap coarse(world, 0.1, 0.25, 0.1), fine(world, 0.05, 0.3, 0.05);
  const SE2 b = a * SE2(0.5, 0.05, 0.1);
  const SE2 twin(W - b.x(), H - b.y(), b.theta() + M_PI);
  const std::vector<Eigen::Vector2d> pts = Downsample(Scan(room, b), 0.1).points;
  // A prediction turned by a 75-degree glitch, searched as the mapper's
  // recovery does.
  const SE2 guess = b * SE2(0.1, -0.1, 1.3);
  CorrelativeOptions o;
  o.linear_window = 2;
  o.angular_window = M_PI;
  o.distance_penalty = 0.02;
  o.runner_up_distance = 0.5;
  o.runner_up_angle = 0.35;
  const CorrelativeResult blind = CorrelativeMatch(coarse, fine, pts, guess, o);
  EXPECT_GT(blind.runner_up_ratio, 0.9);
  const bool found_one = (blind.pose.translation() - b.translation()).norm() < 0.1 ||
                         (blind.pose.translation() - twin.translation()).norm() < 0.1;
  EXPECT_TRUE(found_one);
  o.arc_from = a;
  o.arc_penalty = 0.4;
  const CorrelativeResult seen = CorrelativeMatch(coarse, fine, pts, guess, o);
  EXPECT_LT((seen.pose.translation() - b.translation()).norm(), 0.1);
  EXPECT_LT(std::abs(NormalizeAngle(seen.pose.theta() - b.theta())), 0.05);
  EXPECT_LT(seen.runner_up_ratio, 0.8);
}

}  // namespace
}  // namespace cairn::frontend
