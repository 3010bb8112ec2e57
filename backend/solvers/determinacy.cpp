#include "cairn/solvers/determinacy.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "cairn/factors/pose_manifold.h"
#include "cairn/solvers/graph_factors.h"

namespace cairn {
namespace {

// An eigenvalue below this times the largest of its matrix is a direction
// nothing constrains. Exact freedoms come out as zero or rounding; the
// loosest determined figures seen on the shared files are far above.
constexpr double kFreeRatio = 1e-12;

int RotationSize(int dimension) { return dimension == 2 ? 1 : 3; }

bool Singular(const PoseGraph& graph, const Edge& e) {
  return !IsSymmetricPositiveDefinite(graph.Information(e));
}

// Maps a rigid motion of the whole component (translation a, then rotation
// w about the point c, in the world frame) to the local tangent of pose x
// (translation in the pose's frame, then rotation).
Eigen::MatrixXd WorldToLocal(const PoseGraph& graph, const PoseParams& x, const Eigen::VectorXd& c) {
  if (graph.dimension() == 2) {
    const SE2 pose = ToSE2(x);
    const Eigen::Matrix2d rt = pose.rotation().transpose();
    const Eigen::Vector2d p = pose.translation() - c;
    Eigen::Matrix3d ad = Eigen::Matrix3d::Identity();
    ad.topLeftCorner<2, 2>() = rt;
    ad.topRightCorner<2, 1>() = rt * Eigen::Vector2d(-p.y(), p.x());
    return ad;
  }
  const SE3 pose = ToSE3(x);
  const Eigen::Matrix3d rt = pose.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d p = pose.translation() - c;
  Eigen::Matrix3d skew;
  skew << 0, -p.z(), p.y(), p.z(), 0, -p.x(), -p.y(), p.x(), 0;
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = rt;
  ad.topRightCorner<3, 3>() = -rt * skew;
  ad.bottomRightCorner<3, 3>() = rt;
  return ad;
}

// Eigenvectors of a symmetric matrix whose eigenvalues are free (columns).
Eigen::MatrixXd FreeDirections(const Eigen::MatrixXd& h) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(h);
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  int k = 0;
  while (k < h.rows() && !(eig.eigenvalues()[k] > kFreeRatio * largest)) ++k;
  return eig.eigenvectors().leftCols(k);
}

struct ComponentPriors {
  std::vector<const Edge*> priors;
  bool any_definite = false;
};

// What the priors of a component whose priors are all singular leave of
// its gauge: nothing, its rotations (held at `gauge_vertex`), or something
// else (the message).
void PartialGauge(const PoseGraph& graph, const ComponentPriors& cp, GraphGauge* gauge) {
  const auto manifold =
      graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
  const int d = graph.TangentSize(), r = RotationSize(graph.dimension());
  const Vertex& first = graph.vertex(cp.priors.front()->from);
  const Eigen::VectorXd c = Eigen::Map<const Eigen::VectorXd>(first.x.data(), d - r);
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(d, d);
  int64_t lowest = first.id;
  for (const Edge* e : cp.priors) {
    const LinearizedEdge lin = LinearizeEdge(graph, *e, *manifold);
    const Eigen::MatrixXd a = lin.jacobians[0] * WorldToLocal(graph, graph.vertex(e->from).x, c);
    g += a.transpose() * a;
    lowest = std::min(lowest, e->from);
  }
  const Eigen::MatrixXd free = FreeDirections(g);
  if (free.cols() == 0) return;
  if (free.cols() == r) {
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(free.bottomRows(r));
    if (svd.singularValues().minCoeff() > 1e-6) {
      gauge->rotation_held[graph.VertexIndex(lowest)] = true;
      return;
    }
  }
  if (!gauge->undetermined.empty()) return;
  gauge->undetermined = "vertex " + std::to_string(lowest) + " and its component: " +
                        DescribeDirection(free.col(0), graph.dimension()) +
                        " of the whole component is not fixed by its priors (and no vertex is FIX)";
}

}  // namespace

GraphGauge ComputeGauge(const PoseGraph& graph) {
  const auto& vertices = graph.vertices();
  const std::vector<bool> touched = TouchedVertices(graph);
  GraphGauge gauge;
  gauge.held.assign(vertices.size(), false);
  gauge.rotation_held.assign(vertices.size(), false);
  for (size_t i = 0; i < vertices.size(); ++i) gauge.held[i] = touched[i] && vertices[i].fixed;
  std::vector<std::vector<const Edge*>> priors_at(vertices.size());
  for (const Edge& e : graph.edges())
    if (e.IsPrior()) priors_at[graph.VertexIndex(e.from)].push_back(&e);
  for (const std::vector<int64_t>& component : ConnectedComponents(graph)) {
    bool fixed = false;
    long lowest = -1;  // components come sorted: the first touched is the lowest
    ComponentPriors cp;
    for (int64_t id : component) {
      const size_t i = graph.VertexIndex(id);
      fixed |= gauge.held[i];
      if (lowest < 0 && touched[i]) lowest = static_cast<long>(i);
      for (const Edge* e : priors_at[i]) {
        cp.priors.push_back(e);
        cp.any_definite |= !Singular(graph, *e);
      }
    }
    if (fixed || lowest < 0 || cp.any_definite) continue;
    if (cp.priors.empty()) {
      gauge.held[lowest] = true;
    } else {
      PartialGauge(graph, cp, &gauge);
    }
  }
  return gauge;
}

std::vector<bool> HeldConstant(const PoseGraph& graph) { return ComputeGauge(graph).held; }

std::optional<std::string> FindUndetermined(const PoseGraph& graph, const GraphGauge& gauge) {
  if (!gauge.undetermined.empty()) return gauge.undetermined;
  bool any_singular = false;
  for (const Edge& e : graph.edges()) any_singular = any_singular || Singular(graph, e);
  if (!any_singular) return std::nullopt;
  // A direction of one pose that moves no edge's whitened residual is a
  // null vector of the whole system: its diagonal block says so.
  const auto manifold =
      graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
  const int d = graph.TangentSize(), t = d - RotationSize(graph.dimension());
  std::vector<Eigen::MatrixXd> h(graph.vertices().size());
  for (const Edge& e : graph.edges()) {
    const LinearizedEdge lin = LinearizeEdge(graph, e, *manifold);
    const int64_t ends[2] = {e.from, e.to};
    for (size_t k = 0; k < lin.jacobians.size(); ++k) {
      Eigen::MatrixXd& hk = h[graph.VertexIndex(ends[k])];
      if (hk.size() == 0) hk = Eigen::MatrixXd::Zero(d, d);
      hk += lin.jacobians[k].transpose() * lin.jacobians[k];
    }
  }
  std::string first;
  size_t more = 0;
  for (size_t i = 0; i < h.size(); ++i) {
    if (h[i].size() == 0 || gauge.held[i]) continue;
    const int n = gauge.rotation_held[i] ? t : d;
    const Eigen::MatrixXd free = FreeDirections(h[i].topLeftCorner(n, n));
    if (free.cols() == 0) continue;
    if (!first.empty()) {
      ++more;
      continue;
    }
    Eigen::VectorXd v = Eigen::VectorXd::Zero(d);
    v.head(n) = free.col(0);
    first = "vertex " + std::to_string(graph.vertices()[i].id) + ": " +
            DescribeDirection(v, graph.dimension()) + " is not constrained by any edge";
  }
  if (first.empty()) return std::nullopt;
  if (more > 0) first += " (nor are " + std::to_string(more) + " more vertices in some direction)";
  return first;
}

bool HeldRotationManifold::Plus(const double* x, const double* delta, double* out) const {
  double full[6] = {0, 0, 0, 0, 0, 0};
  std::copy(delta, delta + size_, full);
  return pose_->Plus(x, full, out);
}

bool HeldRotationManifold::PlusJacobian(const double* x, double* jacobian) const {
  const int a = pose_->AmbientSize(), n = pose_->TangentSize();
  double full[7 * 6];
  if (!pose_->PlusJacobian(x, full)) return false;
  for (int r = 0; r < a; ++r)  // row-major: keep the first size_ columns
    for (int c = 0; c < size_; ++c) jacobian[r * size_ + c] = full[r * n + c];
  return true;
}

bool HeldRotationManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  double full[6];
  if (!pose_->Minus(y, x, full)) return false;
  std::copy(full, full + size_, y_minus_x);
  return true;
}

bool HeldRotationManifold::MinusJacobian(const double* x, double* jacobian) const {
  const int a = pose_->AmbientSize();
  double full[6 * 7];
  if (!pose_->MinusJacobian(x, full)) return false;
  std::copy(full, full + size_ * a, jacobian);  // row-major: the first size_ rows
  return true;
}

std::string DescribeDirection(const Eigen::VectorXd& direction, int dimension) {
  const int r = RotationSize(dimension), t = static_cast<int>(direction.size()) - r;
  const Eigen::VectorXd v = direction.normalized();
  static const char* kAxis[] = {"x", "y", "z"};
  Eigen::Index k = 0;
  if (v.cwiseAbs().maxCoeff(&k) > 0.999) {
    if (k < t) return std::string("translation along ") + kAxis[k];
    return std::string("rotation about ") + (dimension == 2 ? "z" : kAxis[k - t]);
  }
  auto vec = [](const Eigen::VectorXd& u) {
    std::string s = "(";
    char buf[32];
    for (Eigen::Index i = 0; i < u.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%s%.2f", i ? ", " : "", u[i]);
      s += buf;
    }
    return s + ")";
  };
  const Eigen::VectorXd tr = v.head(t), rot = v.tail(r);
  if (rot.norm() < 1e-3) return "translation along " + vec(tr.normalized());
  if (tr.norm() < 1e-3 && dimension == 3) return "rotation about " + vec(rot.normalized());
  return "the direction " + vec(v) + " (translation, then rotation)";
}

}  // namespace cairn
