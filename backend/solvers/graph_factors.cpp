#include "cairn/solvers/graph_factors.h"

#include <cmath>

#include "cairn/graph/pose_graph.h"

#include "cairn/factors/landmark_factors.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"

namespace cairn {

namespace {

ceres::CostFunction* MakeLandmarkCost(const PoseGraph& graph, const Edge& edge) {
  if (graph.dimension() == 2) {
    const Eigen::Vector2d z(edge.z[0], edge.z[1]);
    const Eigen::Matrix2d info = edge.information.topLeftCorner<2, 2>();
    return edge.IsPrior() ? factors::PointPriorFactor<2>::Create(z, info)
                          : factors::SE2PointFactor::Create(z, info);
  }
  const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
  const Eigen::Matrix3d info = edge.information.topLeftCorner<3, 3>();
  if (edge.IsPrior()) return factors::PointPriorFactor<3>::Create(z, info);
  const SE3& o = graph.offset(edge.offset);
  return factors::SE3PointFactor::Create(z, o.rotation(), o.translation(), info);
}

}  // namespace

ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge) {
  if (edge.IsLandmark()) return MakeLandmarkCost(graph, edge);
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
    case RobustLoss::kDcs: return std::make_unique<DcsLoss>(loss.delta);
  }
  return nullptr;
}

void DcsLoss::Evaluate(double s, double rho[3]) const {
  if (s <= phi_) {
    rho[0] = s;
    rho[1] = 1;
    rho[2] = 0;
    return;
  }
  const double d = phi_ + s;
  rho[0] = phi_ * (3 * s - phi_) / d;
  rho[1] = 4 * phi_ * phi_ / (d * d);
  rho[2] = -8 * phi_ * phi_ / (d * d * d);
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
  // A fixed pose or a prior on a pose anchors its component; a point does
  // not (the rotation about it stays free), so the gauge is always a pose.
  std::vector<bool> anchors(vertices.size(), false);
  for (size_t i = 0; i < vertices.size(); ++i) {
    held[i] = touched[i] && vertices[i].fixed;
    anchors[i] = held[i] && !vertices[i].landmark;
  }
  for (const Edge& e : graph.edges())
    if (e.kind == EdgeKind::kPrior) anchors[graph.VertexIndex(e.from)] = true;
  for (const std::vector<int64_t>& component : ConnectedComponents(graph)) {
    bool needs_gauge = true;
    long lowest = -1;  // components come sorted: the first touched pose is the lowest
    for (int64_t id : component) {
      const size_t i = graph.VertexIndex(id);
      if (anchors[i]) needs_gauge = false;
      if (lowest < 0 && touched[i] && !vertices[i].landmark) lowest = static_cast<long>(i);
    }
    if (needs_gauge && lowest >= 0) held[lowest] = true;
  }
  return held;
}

std::optional<int64_t> FirstNonFiniteVertex(const PoseGraph& graph) {
  for (const Vertex& v : graph.vertices())
    for (int k = 0; k < graph.BlockSize(v); ++k)
      if (!std::isfinite(v.x[k])) return v.id;
  return std::nullopt;
}

}  // namespace cairn
