// 2D scan matching: a coarse-to-fine correlative search over a likelihood
// field, then point-to-line ICP, with an information matrix estimated from
// the ICP Hessian and a fitness measure for accepting loop closures.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/frontend/carmen_log.h"

namespace cairn::frontend {

// Points in one frame, with unit normals where the neighbourhood allows one
// (has_normal false on isolated points and depth discontinuities).
struct PointCloud {
  std::vector<Eigen::Vector2d> points;
  std::vector<Eigen::Vector2d> normals;
  std::vector<char> has_normal;

  size_t size() const { return points.size(); }
  void Append(const PointCloud& other, const SE2& pose);  // other seen from `pose`
};

// Endpoints of the beams shorter than `max_range` (and longer than
// `min_range`), in the robot frame, with normals from neighbouring beams.
PointCloud ScanToCloud(const LaserScan& scan, double min_range, double max_range);

// One point per cell of size `cell` (the first seen), normals kept.
PointCloud Downsample(const PointCloud& cloud, double cell);

// A reference map for matching: a dense grid that stores, per cell, the
// nearest reference point within `radius` (for ICP correspondences) and a
// smooth likelihood of a hit (for the correlative search).
class MatchMap {
 public:
  MatchMap(const PointCloud& world, double resolution, double radius, double sigma);

  double resolution() const { return res_; }
  // Likelihood in [0, 1] at a continuous cell coordinate.
  float LikelihoodAtCell(int cx, int cy) const {
    if (cx < 0 || cy < 0 || cx >= w_ || cy >= h_) return 0.f;
    const int b = dir_[static_cast<size_t>(cy >> kBlockBits) * bw_ + (cx >> kBlockBits)];
    return b < 0 ? 0.f : like_[Slot(b, cx, cy)];
  }
  // Max-pooled likelihoods for branch and bound: level l holds, at cell
  // (x, y), the highest likelihood over the 2^l x 2^l cells from (x, y) up,
  // so that one look-up bounds a whole square of translations. Level 0 is
  // the field itself; BuildPyramid(L) makes levels 1..L (L <= 4), once: a
  // cache, which is why it is const.
  void BuildPyramid(int levels) const;
  int pyramid_levels() const { return static_cast<int>(pooled_.size()); }
  float PooledAtCell(int level, int cx, int cy) const {
    if (level == 0) return LikelihoodAtCell(cx, cy);
    // A square from below or left of the grid: the one from its edge covers
    // what of it lies inside, a bound though not the exact maximum.
    cx = std::max(cx, 0);
    cy = std::max(cy, 0);
    if (cx >= w_ || cy >= h_ || pdir_.empty()) return 0.f;
    const int b = pdir_[static_cast<size_t>(cy >> kBlockBits) * bw_ + (cx >> kBlockBits)];
    return b < 0 ? 0.f : pooled_[level - 1][Slot(b, cx, cy)];
  }
  // Index of the nearest reference point to p, or -1 beyond the radius.
  int Nearest(const Eigen::Vector2d& p) const;
  const PointCloud& cloud() const { return cloud_; }
  Eigen::Vector2d origin() const { return origin_; }

 private:
  // Cells live in 16 x 16 blocks allocated where points are: a local map of
  // long-range scans spans a large box but touches little of it.
  static constexpr int kBlockBits = 4, kBlockSide = 1 << kBlockBits;
  static size_t Slot(int block, int cx, int cy) {
    return static_cast<size_t>(block) * kBlockSide * kBlockSide +
           ((cy & (kBlockSide - 1)) << kBlockBits) + (cx & (kBlockSide - 1));
  }

  PointCloud cloud_;
  double res_;
  Eigen::Vector2d origin_;
  int w_ = 0, h_ = 0, bw_ = 0;
  std::vector<int> dir_;  // block index per block position, -1 if empty
  std::vector<float> like_;
  // The pyramid, built on first use: its own blocks (those of the field and
  // their neighbours below and left), their positions, the levels 1...
  mutable std::vector<int> pdir_;
  mutable std::vector<std::pair<int, int>> block_pos_;
  mutable std::vector<std::vector<float>> pooled_;
  std::vector<int> nearest_;
};

struct CorrelativeOptions {
  double linear_window = 0.3;   // +- metres around the guess
  double angular_window = 0.17; // +- radians
  double angular_step = 0.0087; // radians, at the fine level
  // Gentle preference for the guess, so that a corridor's flat score does
  // not let the estimate slide along it.
  double distance_penalty = 0.1;
  // The distances (metres, radians) at which that pull is full: the
  // windows when 0, so that widening a window would weaken it.
  double penalty_linear_window = 0, penalty_angular_window = 0;
  // When positive, also find the best coarse score at least this far (metres)
  // from the winner: a close second means repeated structure.
  double runner_up_distance = 0;
  // When positive, a pose this far in heading (radians) from the winner is
  // distinct too, wherever it is: a room turned half round, a corridor
  // seen from its other end.
  double runner_up_angle = 0;
  // When positive, a pose at the winner's heading joined to it by a ridge
  // (the score along the way never below this share of the lower end, as
  // along a corridor) is not distinct: the heading is certain there even
  // if the place along the ridge is not.
  double ridge_share = 0;
  // The coarse level is searched by branch and bound on the coarse map's
  // pyramid (exactly the exhaustive search's best pose); a runner-up ratio
  // below this share may be reported lower than it is (tests against a
  // higher ratio decide the same).
  double runner_up_floor = 0.7;
  // When arc_penalty is positive: the pose the robot was at one scan ago.
  // A wheeled base moves along an arc, so the way it went (seen from
  // `arc_from`) lies near half its turn, seldom backwards; a pose whose
  // heading does not fit the way it moved (a symmetric place's half-turned
  // twin) scores up to arc_penalty lower (ArcMisfit). Short moves say little
  // of the way and are judged only by their turn.
  SE2 arc_from;
  double arc_penalty = 0;
};

// How far the move from `from` to `to` is from what a wheeled base does
// between two scans: 0 (forwards along an arc, turning under a quarter
// turn), 0.5 (backwards along one), up to 1 (the heading does not fit the
// way it went, or a half turn).
double ArcMisfit(const SE2& from, const SE2& to);

struct CorrelativeResult {
  SE2 pose;
  double score = 0;  // mean likelihood of the scan's points, in [0, 1]
  // Coarse score of the best pose runner_up_distance away, over the best's
  // (1 when not computed).
  double runner_up_ratio = 1;
  // That runner-up's coarse pose (the best's when there is none).
  SE2 runner_up;
};

// The best pose on `coarse` (translations on its grid, angular step x2),
// found by branch and bound over its pyramid (built here when missing),
// then a local search on `fine` around it.
CorrelativeResult CorrelativeMatch(const MatchMap& coarse, const MatchMap& fine,
                                   const std::vector<Eigen::Vector2d>& scan, const SE2& guess,
                                   const CorrelativeOptions& options);

struct IcpOptions {
  int max_iterations = 30;
  double max_correspondence = 0.3;  // metres, first iterations
  double min_correspondence = 0.1;  // metres, shrinks to this
  double inlier_distance = 0.1;     // for the fitness figures
  // Covariance = inflation * sigma^2 H^-1 + floor: neighbouring residuals of
  // a scan are correlated, so the raw Hessian is overconfident.
  double covariance_inflation = 20.0;
  double min_sigma_xy = 0.01, min_sigma_theta = 0.003;
  double max_sigma = 1.0;
};

struct IcpResult {
  SE2 pose;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  double inlier_fraction = 0;  // scan points with a reference point within inlier_distance
  double mean_residual = 0;    // mean |point-to-line distance| over inliers, metres
  int inliers = 0;
  bool converged = false;
};

// Point-to-line ICP of `scan` (robot frame) onto `map` (world frame) from
// `guess` (the robot's pose in the world).
IcpResult IcpMatch(const MatchMap& map, const PointCloud& scan, const SE2& guess,
                   const IcpOptions& options);

}  // namespace cairn::frontend
