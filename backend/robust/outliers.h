// Finding wrong loop closures: graduated non-convexity with a truncated
// least-squares cost, with either solver doing the inner weighted
// least-squares solves, then verification and re-admission of single loop
// closures (docs/robustness.md describes the stages).
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <vector>

#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/robust/vertex_pair.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {

// The p-quantile of the chi-squared distribution with `dof` degrees of
// freedom, by bisection on its survival function (closed form for integer
// dof), to a relative 1e-12.
double ChiSquaredQuantile(double p, int dof);

// The chi2 threshold for `loop_closures` loop closures tested at once, so
// that all the good ones pass with probability `confidence` (Bonferroni):
// the 1 - (1 - confidence) / n quantile of chi2 with `dof` degrees of freedom.
// Throws std::invalid_argument unless 0 < confidence < 1.
double LoopClosureThreshold(double confidence, int dof, size_t loop_closures);

struct OutlierRejectionOptions {
  // A loop closure whose chi2 exceeds this is an outlier to the truncated
  // cost; 0 takes LoopClosureThreshold(confidence, 3 or 6, loop closures).
  double threshold_chi2 = 0;
  double confidence = 0.999;
  // GNC's schedule: mu grows by this factor between weighted solves (4
  // since the screened start of the trusted set's least squares; 2 before,
  // when a coarser schedule lost small files' hardest cells).
  double mu_factor = 4;
  int max_rounds = 1000;
  // Iterations of each weighted solve inside GNC (0: the solver's own
  // limit), and the relative decrease of chi2 (and of the gradient) below
  // which it stops (0: the solver's own tolerances): the weights move on
  // before the estimate has settled to its last digits. The last solves,
  // without the rejected loop closures, always run to the solver's own.
  int inner_iterations = 0;
  double inner_tolerance = 1e-4;
  // The largest set of pairwise consistent loop closures
  // (MaximumConsistentSet, pairwise_consistency.h: pairs whose ends lie
  // within this many ids tested, some within ten times as many, and
  // consistency_partners random others per loop closure), less those no
  // neighbour agrees with, goes through GNC first, alone; 0: no such stage.
  int consistency_window = 20;
  int consistency_partners = 20;
  // Tighten the thresholds of the consistency tests and of GNC by the
  // variance factor the data show (chi2 per degree of freedom, at most 1):
  // for information far looser than the noise.
  bool scale_by_variance = true;
  // Iterations of the first least squares on those trusted loop closures
  // (from fresh_init, on those of them that start can hold when it is
  // chordal or auto), before GNC on all of them.
  int trusted_iterations = 20;
  // After that stage, GNC over all loop closures starts where a residual
  // beyond this many times the threshold weighs 0 (mu = 1 / (factor - 1)).
  // GNC on the trusted ones starts where a residual beyond this many times
  // the plain c^2 (not the threshold tightened by the variance factor)
  // weighs 0.
  double restart_chi2_factor = 10;
  // ... and is repeated from its own result, at most gnc_passes times, until
  // the loop closures it keeps no longer change. One by default: a second
  // pass cost as much as the first and changed no decision in the table of
  // docs/robustness.md (re-admission and the take-back of what fits come
  // after it). max_passes bounds the passes of re-admission and take-back.
  int gnc_passes = 1;
  int max_passes = 10;
  // After GNC: reject, one at a time, kept loop closures whose deletion
  // would lower chi2 by more than the threshold (see SolveRejectingOutliers).
  bool verify = true;
  int max_verify_rounds = 100;
  // ... and runs of kept loop closures (linked when both ends lie within
  // group_window ids of another's), as a whole: a run whose deletion would
  // lower chi2 by more than its size times the threshold goes (0: no such
  // test). Aliased groups hold a bend together that no single deletion
  // releases.
  int group_window = 3;
  // After verification: take back rejected loop closures (chi2 within
  // readmit_reach c^2; infinity: all, as good ones to a stretch only they
  // held reach 1000 c^2 once out) whose innovation statistic is within c^2
  // times the a-posteriori variance factor (at most 1) or, where larger,
  // readmit_tail times the 99th percentile of the kept loop closures'
  // deleted-residual statistics at the first pass (never beyond c^2: for
  // noise with a heavier tail than chi2's), then verify again.
  bool readmit = true;
  double readmit_reach = std::numeric_limits<double>::infinity();
  double readmit_tail = 4;
  // At the end: the kept graph solved in full from the estimate reached and
  // from `fresh_init` (kFile: the starting estimate), the lower chi2 kept.
  bool final_solve = true;
  // With final_solve: when the first solve of the kept graph, from GNC's
  // estimate, takes at least this many iterations, the fresh start is
  // tried then too, before the verification (0: only at the end).
  int fresh_check_iterations = 10;
  InitMethod fresh_init = InitMethod::kAuto;
  // Threads for the pairwise tests (0: one per hardware thread); the
  // decision is the same for any count. The solves take the solver's own.
  int threads = 0;
  bool verbose = false;

  // False, with *error saying which option and why, for values out of
  // range; SolveRejectingOutliers throws std::invalid_argument with it.
  bool IsValid(std::string* error) const;
};

struct OutlierRejectionResult {
  // The last solve, on the kept graph, but with the input's chi2 (every
  // edge, at the start) as initial_chi2 and the kept graph's as final_chi2.
  SolveResult solve;
  std::vector<VertexPair> rejected;  // loop closures found wrong, in file order
  std::vector<size_t> rejected_edges;  // the same, as indices into graph.edges()
  int rounds = 0;                  // solves in all (GNC's, the last ones)
  int iterations = 0;              // summed over all the solves
  double solve_time_s = 0;         // the solves' own times, summed
  int verified = 0;                // loop closures rejected by the verification
  double threshold_chi2 = 0;
};

// `graph` without the listed edges (indices into graph.edges(), e.g.
// OutlierRejectionResult::rejected_edges), everything else as it is.
PoseGraph WithoutEdges(const PoseGraph& graph, const std::vector<size_t>& edges);

// What a stage asks of one inner solve: at most `max_iterations` iterations
// (0: the solver's own limit) and, when `tolerance` > 0, a stop once a step
// lowers chi2 by less than that fraction of it or the gradient falls as far
// (the solver's function and gradient tolerances; 0: its own).
struct InnerSolve {
  int max_iterations = 0;
  double tolerance = 0;
};

// A solve of a graph in place (weights are folded into the information),
// within those limits.
using GraphSolver = std::function<SolveResult(PoseGraph& graph, const InnerSolve& limits)>;

// Graduated non-convexity (Yang et al. 2020) for the truncated least squares
// cost sum_i min(chi2_i, c^2) over loop closures; odometry and priors are
// trusted. Starts from the graph's estimate (mu from its largest residual),
// then reweights loop closures between solves while the surrogate cost moves
// from convex to truncated. The weights end binary: those at 0 that still do
// not fit are rejected, and a solve without them follows. Then verification:
// GNC's weights judge each loop closure by its residual at the estimate, and
// the estimate may have bent to fit a wrong one; the deleted-residual
// statistic (backend/robust/leverage.h) predicts how much chi2 would fall without
// it. While some kept loop closure's exceeds the threshold, the largest one
// is rejected too and the rest re-solved: under the truncated cost, a loop
// closure whose deletion saves more than c^2 costs more than leaving it out.
// Then the same for runs of loop closures (group_window): aliased groups
// bend the estimate together, so that deleting any one of them saves
// little; a run whose deletion saves more than its size times c^2 goes.
// Every rejected loop closure that fits the kept graph's solution comes
// back. A kept run under strain is swapped out on trial for the rejected
// loop closures that then cost less in than out, and the swap stays when
// the whole truncated cost falls (GNC's answer can be a local minimum of
// it). The kept graph is solved to its optimum (final_solve). The
// estimate of the last solve is left in `graph`; its edges are not changed.
OutlierRejectionResult SolveRejectingOutliers(PoseGraph& graph, const GraphSolver& solve,
                                              const OutlierRejectionOptions& options = {});

}  // namespace cairn
