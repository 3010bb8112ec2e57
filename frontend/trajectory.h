// Planar trajectories for evaluation: reading them (TUM text, g2o vertices,
// the reference poses of a CARMEN log), writing TUM, and the two standard
// errors: absolute trajectory error after the best rigid alignment and the
// relative pose error over fixed-length segments.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "cairn/graph/geometry.h"

namespace cairn::frontend {

struct Trajectory {
  // Stamps pair poses between trajectories: TUM and CARMEN give times, g2o
  // gives vertex ids (cairn map numbers its vertices by scan index, and a
  // CARMEN trajectory carries its scan indices too).
  std::vector<double> stamps;
  std::vector<std::string> stamp_texts;  // as read, for writing back
  std::vector<SE2> poses;
  std::vector<long> scan_index;  // -1 when unknown
  bool stamps_are_ids = false;

  void Add(double stamp, const SE2& pose, long index = -1, std::string text = {});
  size_t size() const { return poses.size(); }
};

// Reads by content: a file that starts like a CARMEN log (or ends in .log /
// .log.gz) gives its reference poses; a g2o file its VERTEX_SE2 poses;
// otherwise TUM text ("t x y z qx qy qz qw", yaw taken from the quaternion).
// Errors are "FILE:LINE: message" (cairn::ParseError).
Trajectory ReadTrajectory(const std::string& path);

// TUM text: "timestamp x y z qx qy qz qw" with z = 0 and a yaw quaternion.
void WriteTum(const Trajectory& traj, const std::string& path);
void WriteTum(const Trajectory& traj, std::ostream& out);  // for an OutputSet

struct TrajectoryErrors {
  size_t matched = 0;
  double ate_rmse = 0;          // metres
  double rpe_trans_rmse = 0;    // metres, over segments of `segment` m
  double rpe_rot_rmse_deg = 0;  // degrees
  size_t rpe_pairs = 0;
};

// Pairs poses of `est` and `ref`, in est's order: by scan index when both
// know it; a g2o graph's vertex k with the k-th pose of the other file; else
// by stamp. Equal stamps (some logs print times too coarsely to tell scans
// apart) pair in order of appearance when both sides hold as many of them,
// and are left out otherwise.
std::vector<std::pair<size_t, size_t>> Associate(const Trajectory& est, const Trajectory& ref);

// ATE after the least-squares rigid (rotation + translation) alignment of
// est onto ref; RPE over segments of `segment` metres of reference path.
TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& ref,
                                    double segment = 1.0);

}  // namespace cairn::frontend
