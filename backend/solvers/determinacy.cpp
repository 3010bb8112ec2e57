#include "cairn/solvers/determinacy.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <array>
#include <cstdio>
#include <limits>
#include <memory>

#include "cairn/factors/pose_manifold.h"
#include "cairn/solvers/graph_factors.h"

namespace cairn {
namespace {

// An eigenvalue below this times the largest of its matrix (one pose's
// block of J^T J, or the priors' weight on a rigid motion) is a direction
// nothing constrains: exact freedoms come out as zero or rounding.
constexpr double kFreeRatio = 1e-12;
// FreeTogether's: the diagonal added to keep the factorisation going, the
// relative pivot below which a coordinate is looked at, and the weight of
// a direction (relative to the diagonal) below which it is free.
constexpr double kRegularisation = 1e-14;
constexpr double kCandidatePivot = 1e-9;
constexpr double kFreeWeight = 1e-13;

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

// What the priors of a component, all singular, leave of its gauge: their
// whitened Jacobians with respect to a rigid motion of the whole component
// (about its first prior's vertex, for conditioning) tell. Nothing; every
// rotation (then the rotation of the lowest prior vertex is held); or
// something else, which gauge->undetermined says.
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

// The normal equations J^T J of the whitened residuals at the estimate, in
// the tangent coordinates of the poses not held (a held rotation's left
// out): the diagonal blocks per vertex and the whole sparse matrix.
struct NormalEquations {
  std::vector<Eigen::MatrixXd> diagonal;  // per vertex, empty if untouched
  std::vector<int> offset;                // per vertex, -1 if held or untouched
  std::vector<int> size;
  Eigen::SparseMatrix<double> h;
  // Each edge's Jacobians and vertex indices, for J x edge by edge.
  std::vector<LinearizedEdge> edges;
  std::vector<std::array<size_t, 2>> ends;
};

// x^T H x as the sum over edges of |J x|^2: no cancellation, so that a
// direction nothing constrains comes out at rounding squared, not at
// rounding times the largest entry of H.
double Weight(const NormalEquations& ne, const Eigen::VectorXd& x) {
  double sum = 0;
  for (size_t k = 0; k < ne.edges.size(); ++k) {
    const LinearizedEdge& lin = ne.edges[k];
    Eigen::VectorXd jx = Eigen::VectorXd::Zero(lin.residual.size());
    for (size_t a = 0; a < lin.jacobians.size(); ++a) {
      const size_t v = ne.ends[k][a];
      if (ne.offset[v] < 0) continue;
      jx += lin.jacobians[a].leftCols(ne.size[v]) * x.segment(ne.offset[v], ne.size[v]);
    }
    sum += jx.squaredNorm();
  }
  return sum;
}

NormalEquations Assemble(const PoseGraph& graph, const GraphGauge& gauge) {
  const auto manifold =
      graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
  const int d = graph.TangentSize(), t = d - RotationSize(graph.dimension());
  const size_t n = graph.vertices().size();
  NormalEquations ne;
  ne.diagonal.resize(n);
  ne.offset.assign(n, -1);
  ne.size.assign(n, 0);
  const std::vector<bool> touched = TouchedVertices(graph);
  int total = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!touched[i] || gauge.held[i]) continue;
    ne.offset[i] = total;
    ne.size[i] = gauge.rotation_held[i] ? t : d;
    total += ne.size[i];
  }
  std::vector<Eigen::Triplet<double>> entries;
  for (const Edge& e : graph.edges()) {
    ne.edges.push_back(LinearizeEdge(graph, e, *manifold));
    ne.ends.push_back({graph.VertexIndex(e.from), e.IsPrior() ? 0 : graph.VertexIndex(e.to)});
    const LinearizedEdge& lin = ne.edges.back();
    const std::array<size_t, 2>& ends = ne.ends.back();
    for (size_t a = 0; a < lin.jacobians.size(); ++a) {
      Eigen::MatrixXd& block = ne.diagonal[ends[a]];
      if (block.size() == 0) block = Eigen::MatrixXd::Zero(d, d);
      block += lin.jacobians[a].transpose() * lin.jacobians[a];
      for (size_t b = 0; b < lin.jacobians.size(); ++b) {
        const size_t i = ends[a], j = ends[b];
        if (ne.offset[i] < 0 || ne.offset[j] < 0 || ne.offset[i] < ne.offset[j]) continue;
        const Eigen::MatrixXd hij = lin.jacobians[a].leftCols(ne.size[i]).transpose() *
                                    lin.jacobians[b].leftCols(ne.size[j]);
        for (int r = 0; r < ne.size[i]; ++r)
          for (int c = 0; c < ne.size[j]; ++c)
            if (i != j || r >= c) entries.emplace_back(ne.offset[i] + r, ne.offset[j] + c, hij(r, c));
      }
    }
  }
  ne.h.resize(total, total);
  ne.h.setFromTriplets(entries.begin(), entries.end());  // lower triangle, duplicates summed
  return ne;
}

// A direction of one pose that moves no edge's whitened residual is a null
// vector of the whole system: its diagonal block says so.
std::optional<std::string> FreePose(const PoseGraph& graph, const NormalEquations& ne) {
  const int d = graph.TangentSize();
  std::string first;
  size_t more = 0;
  for (size_t i = 0; i < ne.diagonal.size(); ++i) {
    if (ne.offset[i] < 0) continue;
    const int n = ne.size[i];
    const Eigen::MatrixXd free = FreeDirections(ne.diagonal[i].topLeftCorner(n, n));
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

// Poses free only together (beyond a bridge of the graph blind in some
// direction; a stretch of odometry with many such edges). The smallest pivot of the
// LDL^T factorisation (relative to its diagonal entry; a tiny multiple of
// the diagonal keeps it going past a zero) points at the weakest
// coordinate; a few steps of inverse iteration from there give the weakest
// direction x and its weight x^T H x / x^T D x. That is rounding for a
// direction nothing constrains and orders of magnitude more for the most
// ill-conditioned determined graphs measured (docs/robustness.md: about
// 1e-17 to 1e-21 against 3.6e-10 for parking-garage).
std::optional<std::string> FreeTogether(const PoseGraph& graph, const NormalEquations& ne) {
  if (ne.h.rows() == 0) return std::nullopt;
  Eigen::SparseMatrix<double> h = ne.h;
  const Eigen::VectorXd diag = h.diagonal().cwiseMax(std::numeric_limits<double>::min());
  for (int k = 0; k < h.rows(); ++k) h.coeffRef(k, k) += kRegularisation * diag[k];
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt(h);
  if (ldlt.info() != Eigen::Success)
    return std::string("the normal equations are singular (no free direction found)");
  const Eigen::VectorXd pivots = ldlt.vectorD();
  const auto& perm = ldlt.permutationP().indices();  // original k -> its place
  int weakest = 0;
  for (int k = 1; k < h.rows(); ++k)
    if (pivots[perm[k]] / diag[k] < pivots[perm[weakest]] / diag[weakest]) weakest = k;
  if (pivots[perm[weakest]] / diag[weakest] > kCandidatePivot) return std::nullopt;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(h.rows());
  x[weakest] = 1;
  const Eigen::VectorXd root = diag.cwiseSqrt();
  for (int it = 0; it < 4; ++it) {
    const Eigen::VectorXd b = diag.asDiagonal() * x;  // not aliased with the result
    x = ldlt.solve(b);
    x /= x.cwiseProduct(root).cwiseAbs().maxCoeff();  // no overflow along a null
    x /= x.cwiseProduct(root).norm();
  }
  const double weight = Weight(ne, x);  // x^T D x = 1
  if (x.allFinite() && weight > kFreeWeight) return std::nullopt;
  if (!x.allFinite()) x = Eigen::VectorXd::Unit(h.rows(), weakest);
  int k = 0;
  x.cwiseProduct(diag.cwiseSqrt()).cwiseAbs().maxCoeff(&k);
  size_t v = 0;
  while (ne.offset[v] < 0 || k >= ne.offset[v] + ne.size[v]) ++v;
  Eigen::VectorXd dir = Eigen::VectorXd::Zero(graph.TangentSize());
  dir.head(ne.size[v]) = x.segment(ne.offset[v], ne.size[v]);
  return "vertex " + std::to_string(graph.vertices()[v].id) + ": " +
         DescribeDirection(dir, graph.dimension()) +
         " is not constrained by the edges: it moves freely together with other poses";
}

}  // namespace

GraphGauge ComputeGauge(const PoseGraph& graph) {
  const auto& vertices = graph.vertices();
  const std::vector<bool> touched = TouchedVertices(graph);
  GraphGauge gauge;
  gauge.held.assign(vertices.size(), false);
  gauge.rotation_held.assign(vertices.size(), false);
  for (size_t i = 0; i < vertices.size(); ++i) gauge.held[i] = touched[i] && vertices[i].fixed;
  // A fixed pose or a prior on a pose anchors its component (landmark
  // observations join it); a point does not (the rotation about it stays
  // free), so the gauge is always a pose.
  std::vector<Edge> priors;  // copies (the graph gives its edges by value), not moved below
  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (graph.edges().kind(k) == EdgeKind::kPrior) priors.push_back(graph.edges()[k]);
  std::vector<std::vector<const Edge*>> priors_at(vertices.size());
  for (const Edge& e : priors) priors_at[graph.VertexIndex(e.from)].push_back(&e);
  for (const std::vector<int64_t>& component : ConnectedComponents(graph)) {
    bool fixed = false;
    long lowest = -1;  // components come sorted: the first touched pose is the lowest
    ComponentPriors cp;
    for (int64_t id : component) {
      const size_t i = graph.VertexIndex(id);
      fixed |= gauge.held[i] && !vertices[i].landmark;
      if (lowest < 0 && touched[i] && !vertices[i].landmark) lowest = static_cast<long>(i);
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
  // The checks below work on pose blocks; a graph with landmarks and
  // singular information is left to the solvers (not measured yet).
  if (!any_singular || graph.HasLandmarks()) return std::nullopt;
  const NormalEquations normal = Assemble(graph, gauge);
  if (auto local = FreePose(graph, normal)) return local;
  return FreeTogether(graph, normal);
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
