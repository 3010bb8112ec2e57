// What both solvers build from a pose graph: one cost function per edge
// (the factors of factors/), and which vertices are held constant.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <memory>
#include <vector>

#include "backend/pose_graph.h"
#include "backend/solve_result.h"

namespace cairn {

// A new autodiff cost function for the edge (the caller owns it).
ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge);

// Ceres's loss for a RobustLoss (null for none). Ceres's losses act on the
// squared norm s = |r|^2 with the shapes of g2o's kernels of the same width.
std::unique_ptr<ceres::LossFunction> MakeLoss(const RobustLoss& loss);

// Lends a caller-owned loss to a problem that takes ownership of its losses
// (GaussNewtonProblem), so that many residuals can share one.
class BorrowedLoss final : public ceres::LossFunction {
 public:
  explicit BorrowedLoss(const ceres::LossFunction* loss) : loss_(loss) {}
  void Evaluate(double s, double rho[3]) const override { loss_->Evaluate(s, rho); }

 private:
  const ceres::LossFunction* loss_;
};

// Per vertex (in vertices() order): true when some edge touches it, i.e.
// it is a parameter of the problem.
std::vector<bool> TouchedVertices(const PoseGraph& graph);

// Per vertex (in vertices() order): held constant during optimisation. FIX
// vertices are held; when none is and no prior anchors the graph, the
// lowest-id vertex that an edge touches is held as the gauge.
std::vector<bool> HeldConstant(const PoseGraph& graph);

}  // namespace cairn
