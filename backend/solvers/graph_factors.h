// What both solvers build from a pose graph: one cost function per edge
// (the factors of factors/), and which vertices are held constant.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>

#include <Eigen/Core>

#include <memory>
#include <optional>
#include <vector>

#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/gauss_newton.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {

// A new autodiff cost function for the edge (the caller owns it).
ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge);
// What that cost function's Evaluate gives, without making it (its number
// of residuals: PoseGraph::ResidualSize).
bool EvaluateEdge(const PoseGraph& graph, const Edge& edge, const double* const* parameters,
                  double* residuals, double** jacobians);

// The graph's edges as Gauss-Newton residuals, member k being edge k,
// evaluated from the graph at each linearisation (the graph must outlive
// the problem and keep its edges). The square root of each information is
// taken again at each evaluation: keeping it is the memory this saves (the
// cold runs on the shared files are within 2% of the cost functions').
class GraphResiduals final : public ResidualFamily {
 public:
  explicit GraphResiduals(const PoseGraph& graph) : graph_(graph) {}
  int NumResiduals(size_t member) const override {
    return graph_.ResidualSize(graph_.edges().kind(member));
  }
  bool Evaluate(size_t member, const double* const* parameters, double* residuals,
                double** jacobians) const override {
    return EvaluateEdge(graph_, graph_.edges()[member], parameters, residuals, jacobians);
  }

 private:
  const PoseGraph& graph_;
};

// An edge's whitened residual and its Jacobians in the tangent spaces of
// its vertices (one d x d block per vertex: from, then to), at the
// graph's estimate.
struct LinearizedEdge {
  Eigen::VectorXd residual;
  std::vector<Eigen::MatrixXd> jacobians;
};
LinearizedEdge LinearizeEdge(const PoseGraph& graph, const Edge& edge,
                             const ceres::Manifold& manifold);

// Ceres's loss for a RobustLoss (null for none). Ceres's losses act on the
// squared norm s = |r|^2 with the shapes of g2o's kernels of the same width.
std::unique_ptr<ceres::LossFunction> MakeLoss(const RobustLoss& loss);
// The loss as a function of an edge's chi2 (what InitializeAuto compares
// starts by); empty for kNone.
LoopClosureRho LossOfChi2(const RobustLoss& loss);

// Lends a caller-owned loss to a problem that takes ownership of its losses
// (GaussNewtonProblem), so that many residuals can share one.
class BorrowedLoss final : public ceres::LossFunction {
 public:
  explicit BorrowedLoss(const ceres::LossFunction* loss) : loss_(loss) {}
  void Evaluate(double s, double rho[3]) const override { loss_->Evaluate(s, rho); }

 private:
  const ceres::LossFunction* loss_;
};

// Dynamic covariance scaling as a proper loss on s = |r|^2: DCS scales the
// whitened residual by w = min(1, 2 phi / (phi + s)), i.e. weights the
// squared error by w^2, and IRLS with weight rho'(s) = w^2 minimises
//   rho(s) = s                              for s <= phi
//   rho(s) = phi (3 s - phi) / (phi + s)    beyond (continuous to rho'')
// so that Ceres (which uses rho, rho', rho'') and the Gauss-Newton path
// (which reweights by rho') minimise the same function. It tends to 3 phi:
// an outlier costs at most three times the width.
class DcsLoss final : public ceres::LossFunction {
 public:
  explicit DcsLoss(double phi) : phi_(phi) {}
  void Evaluate(double s, double rho[3]) const override;

 private:
  double phi_;
};

// Per vertex (in vertices() order): true when some edge touches it, i.e.
// it is a parameter of the problem.
std::vector<bool> TouchedVertices(const PoseGraph& graph);


// The id of the first vertex whose estimate holds a NaN or infinity: both
// solvers refuse such a start with a message naming it.
std::optional<int64_t> FirstNonFiniteVertex(const PoseGraph& graph);

}  // namespace cairn
