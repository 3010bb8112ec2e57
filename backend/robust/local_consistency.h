// Local pairwise consistency of loop closures: which ones a neighbouring loop
// closure agrees with, around the short cycle the odometry closes between
// them. SolveRejectingOutliers trusts those first.
#pragma once

#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// Two loop closures whose ends both lie within `window` ids of each other's
// form a short cycle with the odometry between their ends (a->c by odometry,
// c->d by the second closure, d->b by odometry, back to a by the first).
// They agree when the cycle's error, in the first closure's frame, is within
// `threshold_chi2` of its covariance (the measurements' covariances
// propagated to first order). Returns, per loop closure (in edge order), how
// many such neighbours agree with it. A pair is skipped when an odometry step
// between their ends is missing. Good loop closures usually come in runs (a
// place revisited is seen from several poses in a row); a wrong one rarely
// has an agreeing neighbour. Throws std::invalid_argument when window < 1.
std::vector<int> LocalLoopClosureSupport(const PoseGraph& graph, int window,
                                         double threshold_chi2);

}  // namespace cairn
