// The SLAM benchmark's own metric (Kümmerle et al. 2009, "On measuring the
// accuracy of SLAM algorithms"): a relations file lists reference
// displacements between the poses at two times, and an estimate is judged by
// how far its own displacements between those poses differ from them. No
// global alignment is involved, so a locally right map with a bent corridor
// scores well where the bend does not cross a relation.
#pragma once

#include <string>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"

namespace cairn::frontend {

// One line "t1 t2 x y z roll pitch yaw": the pose at t2 in the frame of the
// pose at t1 (angles in radians, R = Rz(yaw) Ry(pitch) Rx(roll)).
struct Relation {
  double t1 = 0, t2 = 0;
  SE3 delta;
  size_t line = 0;  // in its file, for messages
};

// '#' lines and blank lines are skipped; anything else malformed is a
// ParseError "FILE:LINE: what".
std::vector<Relation> ReadRelations(const std::string& path);

// How a relation's t1 and t2 find their poses in the estimate: the nearest
// stamp within max_dt, or (a cairn extension for logs whose printed stamps
// repeat) 0-based scan indices matched with the estimate's scan indices.
enum class RelationKey { kStamp, kScanIndex };

struct RelationErrors {
  size_t used = 0;
  // Relations left out: an end with no pose within max_dt (or no such scan),
  // or one whose nearest stamp several poses share.
  size_t unpaired = 0;
  size_t first_unpaired_line = 0;  // 0 when none
  int dimension = 2;               // 3 when the estimate or a relation leaves the plane
  // E = delta_ref^-1 delta_est per relation: |t(E)| (m) and the angle of
  // R(E) (deg), and their squares, as the benchmark's tables give them.
  ErrorStats trans, rot_deg, trans_sq, rot_sq_deg2;
};

RelationErrors EvaluateRelations(const Trajectory& est, const std::vector<Relation>& relations,
                                 RelationKey key, double max_dt = 0.01);

}  // namespace cairn::frontend
