#include "backend/graph_gauss_newton.h"

#include "backend/graph_factors.h"
#include "factors/pose_manifold.h"

namespace cairn {
namespace {

// Lends a caller-owned loss to a problem that would take ownership.
class BorrowedLoss final : public ceres::LossFunction {
 public:
  explicit BorrowedLoss(const ceres::LossFunction* loss) : loss_(loss) {}
  void Evaluate(double s, double rho[3]) const override { loss_->Evaluate(s, rho); }

 private:
  const ceres::LossFunction* loss_;
};

}  // namespace

SolveResult SolveGaussNewton(PoseGraph& graph, const GaussNewtonOptions& options,
                             const ceres::LossFunction* loop_closure_loss) {
  const auto manifold =
      graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
  GaussNewtonProblem problem;
  const std::vector<bool> held = HeldConstant(graph);
  auto& vertices = graph.vertices();
  for (size_t i = 0; i < vertices.size(); ++i)
    problem.AddParameterBlock(vertices[i].x.data(), graph.ParameterSize(), manifold.get());
  for (size_t i = 0; i < vertices.size(); ++i)
    if (held[i]) problem.SetParameterBlockConstant(vertices[i].x.data());
  for (const Edge& e : graph.edges()) {
    std::vector<double*> blocks{graph.vertex(e.from).x.data()};
    if (!e.IsPrior()) blocks.push_back(graph.vertex(e.to).x.data());
    ceres::LossFunction* loss = e.kind == EdgeKind::kLoopClosure && loop_closure_loss
                                    ? new BorrowedLoss(loop_closure_loss)
                                    : nullptr;
    problem.AddResidualBlock(MakeCostFunction(graph, e), loss, blocks);
  }
  return problem.Solve(options);
}

}  // namespace cairn
