// Trajectories for evaluation, planar or in space: reading them (TUM text,
// g2o vertices of a 2D or 3D graph, the reference poses of a CARMEN log) and
// writing TUM. The errors between two of them are frontend/trajectory_eval.h.
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
  // Both views of every pose: the planar one (x, y, yaw) a 2D evaluation
  // uses, and the one in space, where a planar pose sits at z = 0, level.
  std::vector<SE2> poses;
  std::vector<SE3> poses3d;
  std::vector<long> scan_index;  // -1 when unknown
  bool stamps_are_ids = false;
  // 3 for a 3D graph, or once a pose in space leaves the plane (|z|, roll or
  // pitch above kPlanarTolerance): only then is the trajectory evaluated in 3D.
  int dimension = 2;

  void Add(double stamp, const SE2& pose, long index = -1, std::string text = {});
  void Add(double stamp, const SE3& pose, long index = -1, std::string text = {});
  size_t size() const { return poses.size(); }
};

// A TUM line written from a planar pose reads back with z and the quaternion's
// x, y at exactly 0; other tools print rounding noise there.
inline constexpr double kPlanarTolerance = 1e-9;
bool IsPlanar(const SE3& pose);
// The planar view of a pose in space: x, y and the yaw of its rotation.
SE2 PlanarView(const SE3& pose);
SE3 Lift(const SE2& pose);

// Stamps are seconds; beyond this (31,000 years) a file holds nanoseconds.
inline constexpr double kMaxAbsStamp = 1e12;

// Reads by content: a file that starts like a CARMEN log (or ends in .log /
// .log.gz) gives its reference poses; a g2o file its VERTEX_SE2 or
// VERTEX_SE3:QUAT poses (a 3D graph gives a 3D trajectory); cairn map's CSV
// files (header "keyframe,scan,timestamp,x,y,theta" or "scan,timestamp,x,y,
// theta") planar poses with their scan indices, which pair with a log's
// scans even where its printed stamps repeat; otherwise TUM
// text ("timestamp tx ty tz qx qy qz qw", '#' starts a comment line), 3D as
// soon as one pose leaves the plane. Errors are "FILE:LINE: message"
// (cairn::ParseError).
Trajectory ReadTrajectory(const std::string& path);

// TUM text: "timestamp x y z qx qy qz qw"; a planar trajectory with z = 0 and
// a yaw quaternion.
void WriteTum(const Trajectory& traj, const std::string& path);
void WriteTum(const Trajectory& traj, std::ostream& out);  // for an OutputSet

}  // namespace cairn::frontend
