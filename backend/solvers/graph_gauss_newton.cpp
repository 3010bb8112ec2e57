#include "cairn/solvers/graph_gauss_newton.h"

#include <chrono>
#include <limits>
#include <stdexcept>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
SolveResult SolveGaussNewton(PoseGraph& graph, const GaussNewtonOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto start = std::chrono::steady_clock::now();
  if (const auto bad = FirstNonFiniteVertex(graph)) {
    SolveResult result;
    result.solver = "gn";
    result.initial_chi2 = result.final_chi2 = std::numeric_limits<double>::quiet_NaN();
    result.termination = "failure";
    result.message = "vertex " + std::to_string(*bad) + " has a non-finite estimate";
    return result;
  }
  const auto manifold =
      graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
  const GraphGauge gauge = ComputeGauge(graph);
  if (const auto why = FindUndetermined(graph, gauge)) {
    SolveResult result;
    result.solver = "gn";
    result.initial_chi2 = result.final_chi2 = Chi2(graph);
    result.termination = "failure";
    result.message = *why;
    return result;
  }
  const HeldRotationManifold held_rotation(manifold.get(), graph.dimension() == 2 ? 2 : 3);
  const auto loop_closure_loss = MakeLoss(options.loop_closure_loss);
  // The edges are evaluated from the graph: no cost object per edge.
  const GraphResiduals edges(graph);
  GaussNewtonProblem problem;
  problem.Reserve(graph.vertices().size(), graph.edges().size());
  const std::vector<bool>& held = gauge.held;
  auto& vertices = graph.vertices();
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (vertices[i].landmark) {
      // A point: its coordinates, no manifold (the block H gets is 2x2 or 3x3).
      problem.AddParameterBlock(vertices[i].x.data(), graph.BlockSize(vertices[i]));
      continue;
    }
    if (graph.dimension() == 3) {
      // The factors invert quaternions by conjugation, right only for unit
      // ones; normalised as on the Ceres path so both start alike.
      Eigen::Map<Eigen::Quaterniond>(vertices[i].x.data() + 3).normalize();
    }
    problem.AddParameterBlock(vertices[i].x.data(), graph.ParameterSize(),
                              gauge.rotation_held[i] ? &held_rotation : manifold.get());
  }
  for (size_t i = 0; i < vertices.size(); ++i)
    if (held[i]) problem.SetParameterBlockConstant(vertices[i].x.data());
  std::vector<double*> blocks;
  std::vector<int> sizes;
  for (size_t k = 0; k < graph.edges().size(); ++k) {
    const Edge& e = graph.edges()[k];
    blocks.assign(1, graph.vertex(e.from).x.data());
    sizes.assign(1, graph.BlockSize(graph.vertex(e.from)));
    if (!e.IsPrior()) {
      blocks.push_back(graph.vertex(e.to).x.data());
      sizes.push_back(graph.BlockSize(graph.vertex(e.to)));
    }
    ceres::LossFunction* loss = e.kind == EdgeKind::kLoopClosure && loop_closure_loss
                                    ? new BorrowedLoss(loop_closure_loss.get())
                                    : nullptr;
    problem.AddResidualBlock(&edges, k, loss, blocks, sizes);
  }
  const bool robust = options.loop_closure_loss.kind != RobustLoss::kNone;
  const double initial_chi2 = robust ? Chi2(graph) : 0;
  const double build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  SolveResult result = problem.Solve(options);
  // g2o's chi-squared, without the loss, as the Ceres path reports it; the
  // trace holds the robust objective the solver minimised.
  if (robust) {
    result.initial_chi2 = initial_chi2;
    result.final_chi2 = Chi2(graph);
  }
  result.setup_time_s += build_s;
  result.time_s += build_s;
  return result;
}

}  // namespace cairn
