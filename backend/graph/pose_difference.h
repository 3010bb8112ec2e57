// How far apart two estimates of the same graph are, pose by pose: what
// `cairn compare` reports between the solvers and what tests check.
#pragma once

#include "cairn/graph/pose_graph.h"

namespace cairn {

struct PoseDifference {
  double max_translation = 0, rms_translation = 0;    // m, between positions
  double max_rotation_deg = 0, rms_rotation_deg = 0;  // angle of the relative rotation
};

// Over the vertices of `a`, matched by id in `b` (landmarks: their
// positions, in the translation figures); throws std::out_of_range if `b`
// lacks one, std::invalid_argument if the dimensions differ.
PoseDifference ComparePoses(const PoseGraph& a, const PoseGraph& b);

}  // namespace cairn
