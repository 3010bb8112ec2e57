#include "cairn/graph/chi2.h"

#include "cairn/factors/landmark_factors.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"

namespace cairn {

namespace {

// A landmark edge's e^T Omega e, as EdgeChi2.
double LandmarkChi2(const PoseGraph& graph, const Edge& edge, const double* xi, const double* xj) {
  if (graph.dimension() == 2) {
    const Eigen::Vector2d z(edge.z[0], edge.z[1]);
    const Eigen::Matrix2d identity = Eigen::Matrix2d::Identity();
    Eigen::Vector2d e;
    if (edge.IsPrior()) {
      factors::PointPriorFactor<2>(z, identity)(xi, e.data());
    } else {
      factors::SE2PointFactor(z, identity)(xi, xj, e.data());
    }
    return e.dot(edge.information.topLeftCorner<2, 2>() * e);
  }
  const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  Eigen::Vector3d e;
  if (edge.IsPrior()) {
    factors::PointPriorFactor<3>(z, identity)(xi, e.data());
  } else {
    const SE3& o = graph.offset(edge.offset);
    factors::SE3PointFactor(z, o.rotation().normalized(), o.translation(), identity)(xi, xj,
                                                                                     e.data());
  }
  return e.dot(edge.information.topLeftCorner<3, 3>() * e);
}

}  // namespace

// Evaluates the factor functors with plain doubles and the information
// itself in place of its square root: e^T Omega e without a factorisation.
double EdgeChi2(const PoseGraph& graph, const Edge& edge) {
  const double* xi = graph.vertex(edge.from).x.data();
  const double* xj = edge.IsPrior() ? nullptr : graph.vertex(edge.to).x.data();
  if (edge.IsLandmark()) return LandmarkChi2(graph, edge, xi, xj);
  if (graph.dimension() == 2) {
    const Eigen::Vector3d z(edge.z[0], edge.z[1], edge.z[2]);
    const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
    Eigen::Vector3d e;
    if (edge.IsPrior()) {
      factors::SE2PriorFactor(z, identity)(xi, e.data());
    } else {
      factors::SE2BetweenFactor(z, identity)(xi, xj, e.data());
    }
    return e.dot(edge.information.topLeftCorner<3, 3>() * e);
  }
  const SE3 z = ToSE3(edge.z);
  const Matrix6d identity = Matrix6d::Identity();
  Eigen::Matrix<double, 6, 1> e;
  if (edge.IsPrior()) {
    factors::SE3PriorFactor(z.rotation(), z.translation(), identity)(xi, e.data());
  } else {
    factors::SE3BetweenFactor(z.rotation(), z.translation(), identity)(xi, xj, e.data());
  }
  return e.dot(edge.information.Full() * e);
}

double Chi2(const PoseGraph& graph) {
  double sum = 0;
  for (const Edge& e : graph.edges()) sum += EdgeChi2(graph, e);
  return sum;
}

}  // namespace cairn
