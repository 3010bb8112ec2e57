#include "backend/graph_factors.h"

#include "factors/se2_factors.h"
#include "factors/se3_factors.h"

namespace cairn {

ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge) {
  if (graph.dimension() == 2) {
    const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
    const Eigen::Matrix3d info = edge.information.topLeftCorner<3, 3>();
    return edge.IsPrior() ? factors::SE2PriorFactor::Create(z, info)
                          : factors::SE2BetweenFactor::Create(z, info);
  }
  const SE3 z = ToSE3(edge.z);
  return edge.IsPrior()
             ? factors::SE3PriorFactor::Create(z.rotation(), z.translation(), edge.information)
             : factors::SE3BetweenFactor::Create(z.rotation(), z.translation(), edge.information);
}

std::unique_ptr<ceres::LossFunction> MakeLoss(const RobustLoss& loss) {
  switch (loss.kind) {
    case RobustLoss::kNone: return nullptr;
    case RobustLoss::kHuber: return std::make_unique<ceres::HuberLoss>(loss.delta);
    case RobustLoss::kCauchy: return std::make_unique<ceres::CauchyLoss>(loss.delta);
  }
  return nullptr;
}

std::vector<bool> TouchedVertices(const PoseGraph& graph) {
  std::vector<bool> touched(graph.vertices().size(), false);
  for (const Edge& e : graph.edges()) {
    touched[graph.VertexIndex(e.from)] = true;
    if (!e.IsPrior()) touched[graph.VertexIndex(e.to)] = true;
  }
  return touched;
}

std::vector<bool> HeldConstant(const PoseGraph& graph) {
  const auto& vertices = graph.vertices();
  const std::vector<bool> touched = TouchedVertices(graph);
  std::vector<bool> held(vertices.size(), false);
  bool any = false;
  for (size_t i = 0; i < vertices.size(); ++i) any |= held[i] = touched[i] && vertices[i].fixed;
  if (any || graph.CountEdges(EdgeKind::kPrior) > 0) return held;
  long lowest = -1;
  for (size_t i = 0; i < vertices.size(); ++i)
    if (touched[i] && (lowest < 0 || vertices[i].id < vertices[lowest].id)) lowest = static_cast<long>(i);
  if (lowest >= 0) held[lowest] = true;
  return held;
}

}  // namespace cairn
