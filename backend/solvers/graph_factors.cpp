#include "cairn/solvers/graph_factors.h"

#include <cmath>
#include <memory>
#include <stdexcept>

#include "cairn/graph/pose_graph.h"

#include "cairn/factors/landmark_factors.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"

namespace cairn {

namespace {

template <typename T>
struct Factor {
  using type = T;
};

// Calls make(Factor<F>{}, args...) with the factor F of the edge and the
// arguments its Create and Evaluate take (the measurement and information),
// so that building a cost function and evaluating without one cannot
// disagree on what an edge means.
template <typename Make>
auto WithFactor(const PoseGraph& graph, const Edge& edge, Make&& make) {
  if (edge.IsLandmark()) {
    if (graph.dimension() == 2) {
      const Eigen::Vector2d z(edge.z[0], edge.z[1]);
      const Eigen::Matrix2d info = edge.information.topLeftCorner<2, 2>();
      return edge.IsPrior() ? make(Factor<factors::PointPriorFactor<2>>{}, z, info)
                            : make(Factor<factors::SE2PointFactor>{}, z, info);
    }
    const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
    const Eigen::Matrix3d info = edge.information.topLeftCorner<3, 3>();
    if (edge.IsPrior()) return make(Factor<factors::PointPriorFactor<3>>{}, z, info);
    const SE3& o = graph.offset(edge.offset);
    return make(Factor<factors::SE3PointFactor>{}, z, o.rotation(), o.translation(), info);
  }
  if (graph.dimension() == 2) {
    const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
    const Eigen::Matrix3d info = edge.information.topLeftCorner<3, 3>();
    return edge.IsPrior() ? make(Factor<factors::SE2PriorFactor>{}, z, info)
                          : make(Factor<factors::SE2BetweenFactor>{}, z, info);
  }
  const SE3 z = ToSE3(edge.z);
  const Matrix6d info = edge.information;
  return edge.IsPrior() ? make(Factor<factors::SE3PriorFactor>{}, z.rotation(), z.translation(), info)
                        : make(Factor<factors::SE3BetweenFactor>{}, z.rotation(), z.translation(),
                               info);
}

}  // namespace

ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge) {
  return WithFactor(graph, edge, [](auto factor, const auto&... args) -> ceres::CostFunction* {
    return decltype(factor)::type::Create(args...);
  });
}

bool EvaluateEdge(const PoseGraph& graph, const Edge& edge, const double* const* parameters,
                  double* residuals, double** jacobians) {
  return WithFactor(graph, edge, [&](auto factor, const auto&... args) {
    return decltype(factor)::type::Evaluate(args..., parameters, residuals, jacobians);
  });
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

LoopClosureRho LossOfChi2(const RobustLoss& loss) {
  std::shared_ptr<const ceres::LossFunction> f = MakeLoss(loss);
  if (!f) return {};
  return [f](double chi2) {
    double rho[3];
    f->Evaluate(chi2, rho);
    return rho[0];
  };
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

LinearizedEdge LinearizeEdge(const PoseGraph& graph, const Edge& edge,
                             const ceres::Manifold& manifold) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  if (edge.IsLandmark()) throw std::invalid_argument("LinearizeEdge: a landmark edge");
  const std::unique_ptr<ceres::CostFunction> cost(MakeCostFunction(graph, edge));
  const int d = graph.TangentSize(), p = graph.ParameterSize();
  std::vector<const double*> params = {graph.vertex(edge.from).x.data()};
  if (!edge.IsPrior()) params.push_back(graph.vertex(edge.to).x.data());
  std::vector<RowMajor> ambient(params.size(), RowMajor(d, p));
  std::vector<double*> jac_ptrs;
  for (RowMajor& a : ambient) jac_ptrs.push_back(a.data());
  LinearizedEdge out;
  out.residual.resize(d);
  if (!cost->Evaluate(params.data(), out.residual.data(), jac_ptrs.data()))
    throw std::runtime_error("an edge's residual could not be evaluated");
  for (size_t k = 0; k < params.size(); ++k) {
    RowMajor plus(p, d);
    manifold.PlusJacobian(params[k], plus.data());
    out.jacobians.push_back(ambient[k] * plus);
  }
  return out;
}

std::optional<int64_t> FirstNonFiniteVertex(const PoseGraph& graph) {
  for (const Vertex& v : graph.vertices())
    for (int k = 0; k < graph.BlockSize(v); ++k)
      if (!std::isfinite(v.x[k])) return v.id;
  return std::nullopt;
}

}  // namespace cairn
