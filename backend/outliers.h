// Wrong loop closures: adding them on purpose (to measure robustness) and
// finding them (graduated non-convexity with a truncated least-squares cost),
// with either solver doing the inner weighted least-squares solves.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "backend/pose_graph.h"
#include "backend/solve_result.h"

namespace cairn {

using VertexPair = std::pair<int64_t, int64_t>;

// Adds `count` loop closures between random pairs of distinct, non-consecutive
// vertices not yet joined, each with a random measurement (translation
// uniform within the largest loop-closure translation, rotation uniform) and
// the information of the graph's median loop closure (by trace; the median
// odometry edge's when there is none). Returns the pairs added, in order.
// Throws std::invalid_argument when the graph is too small to take them.
std::vector<VertexPair> AddWrongLoopClosures(PoseGraph& graph, int count, uint64_t seed);

// The p-quantile of the chi-squared distribution with `dof` degrees of
// freedom (Wilson-Hilferty: within 2% for dof >= 3 and p in [0.9, 0.999]).
double ChiSquaredQuantile(double p, int dof);

struct OutlierRejectionOptions {
  // A loop closure whose chi2 exceeds this is an outlier to the truncated
  // cost; 0 takes the `confidence` quantile of chi2 with 3 (2D) or 6 (3D) dof.
  double threshold_chi2 = 0;
  double confidence = 0.999;
  // GNC's schedule: mu grows by this factor between weighted solves.
  double mu_factor = 1.4;
  int max_rounds = 1000;
  bool verbose = false;
};

struct OutlierRejectionResult {
  SolveResult solve;               // the last solve, on the inliers alone
  std::vector<VertexPair> rejected;  // loop closures found wrong, in file order
  int rounds = 0;                  // weighted solves GNC took
  double threshold_chi2 = 0;
};

// A solve of a graph in place (weights are folded into the information).
using GraphSolver = std::function<SolveResult(PoseGraph&)>;

// Graduated non-convexity (Yang et al. 2020) for the truncated least squares
// cost sum_i min(chi2_i, c^2) over loop closures; odometry and priors are
// trusted. Starts from the least-squares solution, then reweights loop
// closures between solves while the surrogate cost moves from convex to
// truncated. The weights end binary: those at 0 are the rejected loop
// closures, and a last solve without them leaves the estimate in `graph`.
OutlierRejectionResult SolveRejectingOutliers(PoseGraph& graph, const GraphSolver& solve,
                                              const OutlierRejectionOptions& options = {});

}  // namespace cairn
