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

std::vector<bool> HeldConstant(const PoseGraph& graph) {
  const auto& vertices = graph.vertices();
  std::vector<bool> held(vertices.size(), false);
  bool any = false;
  for (size_t i = 0; i < vertices.size(); ++i) any |= held[i] = vertices[i].fixed;
  if (any || graph.CountEdges(EdgeKind::kPrior) > 0 || vertices.empty()) return held;
  size_t lowest = 0;
  for (size_t i = 1; i < vertices.size(); ++i)
    if (vertices[i].id < vertices[lowest].id) lowest = i;
  held[lowest] = true;
  return held;
}

}  // namespace cairn
