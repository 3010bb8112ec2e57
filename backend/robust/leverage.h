// Leave-one-out statistics of a pose graph's edges at its current estimate
// (normally a least-squares optimum): how much chi2 would fall if one edge
// were deleted and the graph re-solved, without re-solving. The estimate can
// bend to fit a wrong edge; its own residual is then small, but deleting it
// releases the tension it put on the rest of the graph. The deleted-residual
// statistic measures that tension.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// For each listed edge (indices into graph.edges(), between-edges), the
// deleted-residual statistic  r^T (I - J Sigma J^T)^{-1} r : r the edge's
// whitened residual, J its whitened Jacobian in both poses' tangent spaces,
// Sigma their joint covariance (the inverse of the Gauss-Newton information
// matrix of the whole graph, with the solvers' gauge). For a linear problem
// it is exactly the fall of the optimal chi2 when the edge is deleted; an
// edge that was right is chi2-distributed with 3 (2D) or 6 (3D) degrees of
// freedom. NaN when deleting the edge would leave a direction unobserved
// (it was the only constraint on it): there is then nothing to compare with. Throws std::runtime_error
// when the information matrix is not positive definite.
//
// Sigma's entries on the pattern of the sparse Cholesky factor (which holds
// every edge's pose pairs) come from Takahashi's recurrence, so the cost is
// about one factorisation, not one solve per edge.
std::vector<double> DeletedResidualChi2(const PoseGraph& graph, const std::vector<size_t>& edges);

// The same for groups of edges deleted together (each a list of indices
// into graph.edges(), between-edges): r_G^T (I - J_G Sigma J_G^T)^{-1} r_G
// over the group's stacked whitened residuals, Sigma the exact joint
// covariance of every pose the group touches. For a linear problem, the fall
// of the optimal chi2 when the whole group goes; a group of n right edges
// is chi2 with 3n (2D) or 6n (3D) degrees of freedom. Wrong loop closures
// that agree with each other hold a bend together that deleting any one of
// them would not release: only the group's statistic sees it. NaN as above.
//
// Each group costs forward solves that walk the elimination tree from its
// poses (their Gram matrix is J_G Sigma J_G^T); one factorisation serves
// them all.
std::vector<double> GroupDeletedResidualChi2(const PoseGraph& graph,
                                             const std::vector<std::vector<size_t>>& groups);

// For loop closures not in the graph (between-edges of its vertices): the
// innovation statistic r^T (I + J Sigma J^T)^{-1} r, how much the optimal
// chi2 would rise (linear problem) if the edge were added, with Sigma the
// exact joint covariance of its two poses (H X = E solved for their
// columns), and the largest eigenvalue of J Sigma J^T (`spread`: how loosely
// the graph holds the pair relative to the edge's own covariance).
// With `screen` finite, a candidate whose statistic provably exceeds it is
// not computed exactly: its chi2 is then a lower bound above `screen` (from
// the two poses' own covariance blocks, S <= 2 diag(S_aa, S_bb)), spread
// NaN and exact false. Far-apart wrong loop closures cost a long walk of
// the elimination tree each; the bound needs none.
struct InnovationStat {
  double chi2;
  double spread;
  bool exact = true;
};
std::vector<InnovationStat> InnovationChi2(
    const PoseGraph& graph, const std::vector<Edge>& candidates,
    double screen = std::numeric_limits<double>::infinity());

}  // namespace cairn
