#include "cairn/robust/kernel_warm_start.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/graph_factors.h"

namespace cairn {

bool KernelWarmStartOptions::IsValid(std::string* error) const {
  const char* why = nullptr;
  if (!(min_weight >= 0 && min_weight < 1))
    why = "the warm start's min_weight must lie in [0, 1)";
  else if (max_rounds < 0)
    why = "the warm start's max_rounds must not be negative";
  if (why && error) *error = why;
  return !why;
}

namespace {

// Per edge: a loop closure whose kernel weight at the graph's estimate is
// below `min_weight` (not a number counts as below).
std::vector<bool> Negligible(const PoseGraph& graph, const ceres::LossFunction& loss,
                             double min_weight, size_t* count) {
  std::vector<bool> out(graph.edges().size(), false);
  *count = 0;
  for (size_t k = 0; k < out.size(); ++k) {
    const Edge& e = graph.edges()[k];
    if (e.kind != EdgeKind::kLoopClosure) continue;
    double rho[3];
    loss.Evaluate(EdgeChi2(graph, e), rho);
    out[k] = !(rho[1] >= min_weight);
    *count += out[k];
  }
  return out;
}

void Accumulate(const SolveResult& r, SolveResult* total) {
  total->iterations += r.iterations;
  total->time_s += r.time_s;
}

}  // namespace

SolveResult SolveKernelWarmStarted(PoseGraph& graph, const RobustLoss& loss,
                                   const GraphSolver& solve,
                                   const KernelWarmStartOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const std::unique_ptr<ceres::LossFunction> rho = MakeLoss(loss);
  SolveResult total;
  total.initial_chi2 = Chi2(graph);
  std::vector<bool> left_out_before;
  for (int round = 0; rho && round < options.max_rounds; ++round) {
    size_t count = 0;
    const std::vector<bool> left_out = Negligible(graph, *rho, options.min_weight, &count);
    if (count == 0 || left_out == left_out_before) break;
    PoseGraph sub = graph;
    std::vector<bool> keep(left_out.size());
    for (size_t k = 0; k < keep.size(); ++k) keep[k] = !left_out[k];
    sub.KeepEdges(keep);
    const SolveResult r = solve(sub, InnerSolve{});
    Accumulate(r, &total);
    if (options.verbose)
      std::fprintf(stderr,
                   "kernel warm start, round %d: %zu loop closures weighed below %.3g left out, "
                   "%d iterations, %.2f s\n",
                   round + 1, count, options.min_weight, r.iterations, r.time_s);
    if (!r.usable) break;  // the whole graph's solve from where it was
    for (size_t i = 0; i < graph.vertices().size(); ++i)
      graph.vertices()[i].x = sub.vertices()[i].x;
    left_out_before = left_out;
  }
  const SolveResult last = solve(graph, InnerSolve{});
  const int iterations = total.iterations + last.iterations;
  const double time_s = total.time_s + last.time_s;
  const double initial = total.initial_chi2;
  total = last;
  total.iterations = iterations;
  total.time_s = time_s;
  total.initial_chi2 = initial;
  return total;
}

}  // namespace cairn
