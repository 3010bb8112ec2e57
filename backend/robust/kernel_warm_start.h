// A robust kernel's solve warm-started without the loop closures it weighs
// at nearly nothing: on a graph with wrong loop closures, their weight is
// tiny but their fill-in in every factorisation is not (far-apart poses
// joined), so each iteration of the plain solve costs several clean ones.
#pragma once

#include <string>

#include "cairn/graph/pose_graph.h"
#include "cairn/robust/outliers.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {

struct KernelWarmStartOptions {
  // A loop closure whose kernel weight rho'(chi2) at the current estimate is
  // below this is left out of a warm-up round (DCS at phi 1: chi2 beyond
  // about 2000).
  double min_weight = 1e-6;
  // Warm-up rounds at most; each solves the graph without the loop closures
  // below min_weight, until the set left out repeats.
  int max_rounds = 10;
  bool verbose = false;

  // False, with the reason in *error when given, for a value out of range.
  bool IsValid(std::string* error = nullptr) const;
};

// Minimises the robust cost (loop closures through `loss`, the rest by
// chi2) of `graph` in place, with `solve` (which must apply the same loss).
// Warm-up rounds solve the graph without the loop closures whose weight is
// below options.min_weight; the last solve is of the whole graph from
// there, to the solver's own tolerances, so the result is a converged
// solution of the whole problem (on the corrupted files of
// docs/robustness.md it takes 0-2 iterations). No loop closure below the
// weight at the start: one plain solve. The result covers every solve
// (iterations and time summed, the input's chi2, the last solve's
// outcome). Throws std::invalid_argument on bad options.
SolveResult SolveKernelWarmStarted(PoseGraph& graph, const RobustLoss& loss,
                                   const GraphSolver& solve,
                                   const KernelWarmStartOptions& options = {});

}  // namespace cairn
