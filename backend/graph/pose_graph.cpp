#include "cairn/graph/pose_graph.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>

namespace cairn {

const char* ToString(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry: return "odometry";
    case EdgeKind::kLoopClosure: return "loop closure";
    case EdgeKind::kPrior: return "prior";
  }
  return "?";
}

PoseGraph::PoseGraph(int dimension) : dimension_(dimension) {
  if (dimension != 2 && dimension != 3) throw std::invalid_argument("dimension must be 2 or 3");
}

Vertex& PoseGraph::AddVertex(int64_t id, const PoseParams& x, bool fixed) {
  if (HasVertex(id)) throw std::invalid_argument("duplicate vertex id " + std::to_string(id));
  index_.emplace(id, vertices_.size());
  vertices_.push_back(Vertex{id, x, fixed});
  return vertices_.back();
}

Vertex& PoseGraph::AddVertex(int64_t id, const SE2& pose, bool fixed) {
  if (dimension_ != 2) throw std::invalid_argument("an SE2 vertex in a 3D graph");
  return AddVertex(id, ToParams(pose), fixed);
}

Vertex& PoseGraph::AddVertex(int64_t id, const SE3& pose, bool fixed) {
  if (dimension_ != 3) throw std::invalid_argument("an SE3 vertex in a 2D graph");
  return AddVertex(id, ToParams(pose), fixed);
}

void PoseGraph::AddEdge(const Edge& edge) {
  if (!HasVertex(edge.from))
    throw std::invalid_argument("edge to vertex " + std::to_string(edge.from) +
                                ", which does not exist");
  if (!edge.IsPrior()) {
    if (!HasVertex(edge.to))
      throw std::invalid_argument("edge to vertex " + std::to_string(edge.to) +
                                  ", which does not exist");
    if (edge.from == edge.to)
      throw std::invalid_argument("edge joins vertex " + std::to_string(edge.from) +
                                  " to itself");
  }
  if (!IsSymmetricPositiveDefinite(Information(edge)))
    throw std::invalid_argument("information matrix is not symmetric positive definite");
  edges_.push_back(edge);
  if (dimension_ == 2) {
    // Keep the unused parts canonical so that equal edges compare equal.
    Edge& e = edges_.back();
    const Eigen::Matrix3d used = e.information.topLeftCorner<3, 3>();
    e.information.setZero();
    e.information.topLeftCorner<3, 3>() = used;
    std::fill(e.z.begin() + 3, e.z.end(), 0.0);
  }
}

size_t PoseGraph::CountEdges(EdgeKind kind) const {
  size_t n = 0;
  for (const Edge& e : edges_) n += e.kind == kind;
  return n;
}

size_t PoseGraph::CountFixed() const {
  size_t n = 0;
  for (const Vertex& v : vertices_) n += v.fixed;
  return n;
}

Eigen::MatrixXd PoseGraph::Information(const Edge& e) const {
  const int n = TangentSize();
  return e.information.topLeftCorner(n, n);
}

SE2 ToSE2(const PoseParams& p) { return SE2(p[0], p[1], p[2]); }

SE3 ToSE3(const PoseParams& p) { return SE3::FromVector(Eigen::Map<const Vector7d>(p.data())); }

PoseParams ToParams(const SE2& pose) { return {pose.x(), pose.y(), pose.theta(), 0, 0, 0, 0}; }

PoseParams ToParams(const SE3& pose) {
  PoseParams p;
  Eigen::Map<Vector7d>(p.data()) = pose.ToVector();
  return p;
}

EdgeKind KindForBetween(int64_t from, int64_t to) {
  return (to == from + 1 || from == to + 1) ? EdgeKind::kOdometry : EdgeKind::kLoopClosure;
}

bool IsSymmetricPositiveDefinite(const Eigen::MatrixXd& info) {
  if (!info.allFinite()) return false;
  const double scale = info.cwiseAbs().maxCoeff();
  if (!(scale > 0)) return false;
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  Eigen::LLT<Eigen::MatrixXd> llt(info);
  if (llt.info() != Eigen::Success) return false;
  // A factor with a zero pivot passes LLT in floating point; demand a real one.
  return llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0;
}

}  // namespace cairn
