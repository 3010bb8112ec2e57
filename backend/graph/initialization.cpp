#include "cairn/graph/initialization.h"

#include <Eigen/SVD>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/runtime.h"
#include "cairn/linear/sparse_cholesky.h"

namespace cairn {
namespace {

// Index of each component's root (fixed vertex first, else lowest id), by
// vertex index: root_of[i] is true for roots. Components by between-edges
// only: a relative pose cannot be chained, nor a rotation solved, through a
// point, so poses tied only through landmarks keep their own roots' poses.
std::vector<bool> ComponentRoots(const PoseGraph& graph) {
  const auto components = ConnectedComponents(graph, /*through_landmarks=*/false);
  std::vector<bool> root(graph.vertices().size(), false);
  for (const auto& ids : components) {
    int64_t chosen = ids.front();
    for (int64_t id : ids)
      if (graph.vertex(id).fixed) {
        chosen = id;
        break;
      }
    root[graph.VertexIndex(chosen)] = true;
  }
  return root;
}

// Blocks of at most 3x3 (3 right-hand sides), kept on the stack: the
// chordal step builds a few of them per edge.
using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;

// A factorisation kept from one system to the next while the pattern, kept
// beside it, stays the same.
struct SharedCholesky {
  std::unique_ptr<SparseCholesky> factor;
  std::vector<int> col_ptr, rows;
};

// A sparse symmetric system over blocks of size d, with some blocks known
// (anchored): their terms move to the right-hand side. `rhs_columns`
// right-hand sides share one factorisation.
class BlockSystem {
 public:
  BlockSystem(const std::vector<bool>& anchored, int d, int rhs_columns)
      : d_(d), index_(anchored.size(), -1) {
    int n = 0;
    for (size_t i = 0; i < anchored.size(); ++i)
      if (!anchored[i]) index_[i] = n++;
    n_ = n;
    b_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n) * d, rhs_columns);
  }

  // Adds the residual A_i x_i + A_j x_j - c (weight W) for vertices i, j;
  // `known` gives the values of anchored blocks (d x rhs_columns each).
  void AddResidual(size_t i, const Block& ai, size_t j, const Block& aj,
                   const Block& c, const Block& w,
                   const std::vector<Block>& known) {
    // Move anchored terms into the constant: r = A_u x_u - (c - A_a x_a).
    Block rhs = c;
    if (index_[i] < 0) rhs -= ai * known[i];
    if (index_[j] < 0) rhs -= aj * known[j];
    const std::pair<size_t, const Block*> terms[2] = {{i, &ai}, {j, &aj}};
    for (const auto& [p, ap] : terms) {
      if (index_[p] < 0) continue;
      b_.middleRows(static_cast<Eigen::Index>(index_[p]) * d_, d_) += ap->transpose() * w * rhs;
      for (const auto& [q, aq] : terms) {
        if (index_[q] < 0) continue;
        AddBlock(index_[p], index_[q], ap->transpose() * w * *aq);
      }
    }
  }

  void Reserve(size_t residuals) { triplets_.reserve(residuals * 3 * d_ * d_); }

  // Solves and returns the unknown blocks (by vertex index; anchored: empty).
  // CHOLMOD with the block ordering, as the Gauss-Newton path factorises.
  // Both stages' systems have the same pattern (every edge between poses,
  // whole blocks): the analysis, most of the cost on large graphs, is made
  // once in `*cholesky` and kept for the next system.
  std::vector<Block> Solve(SharedCholesky* cholesky) {
    const int size = n_ * d_;
    std::vector<Block> out(index_.size());
    if (size == 0) return out;
    Eigen::SparseMatrix<double> h(size, size);
    h.setFromTriplets(triplets_.begin(), triplets_.end());
    triplets_ = {};
    h.makeCompressed();
    std::vector<int> col_ptr(h.outerIndexPtr(), h.outerIndexPtr() + size + 1);
    std::vector<int> rows(h.innerIndexPtr(), h.innerIndexPtr() + h.nonZeros());
    if (!cholesky->factor || col_ptr != cholesky->col_ptr || rows != cholesky->rows) {
      cholesky->factor = SparseCholesky::Create(Factorization::kSupernodalOrSimplicial);
      cholesky->factor->Analyze(size, col_ptr, rows, std::vector<int>(n_, d_));
      cholesky->col_ptr = std::move(col_ptr);
      cholesky->rows = std::move(rows);
    }
    std::copy(h.valuePtr(), h.valuePtr() + h.nonZeros(), cholesky->factor->values());
    if (!cholesky->factor->Factorize())
      throw std::runtime_error("chordal initialisation: singular linear system");
    Eigen::MatrixXd x(size, b_.cols());
    for (Eigen::Index c = 0; c < b_.cols(); ++c) cholesky->factor->Solve(b_.col(c).data(), x.col(c).data());
    if (!x.allFinite()) throw std::runtime_error("chordal initialisation: no finite solution");
    for (size_t v = 0; v < index_.size(); ++v)
      if (index_[v] >= 0) out[v] = x.middleRows(static_cast<Eigen::Index>(index_[v]) * d_, d_);
    return out;
  }

 private:
  // The upper triangle only, zeros included: every block is whole, as the
  // block ordering expects.
  void AddBlock(int r, int c, const Block& m) {
    if (r > c) return;
    for (int a = 0; a < d_; ++a)
      for (int b = 0; b < d_; ++b)
        if (r < c || a <= b) triplets_.emplace_back(r * d_ + a, c * d_ + b, m(a, b));
  }

  int d_, n_ = 0;
  std::vector<int> index_;
  Eigen::MatrixXd b_;
  std::vector<Eigen::Triplet<double>> triplets_;
};

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// The chordal relaxation's first stage: R_j = R_i Z over unconstrained
// matrices, i.e. for the transposed rows a = R^T, a_j = Z^T a_i: residual
// a_j - Z^T a_i, all d columns at once. Returns each free vertex's solved
// R^T (not yet a rotation); anchored ones keep `rot`.
std::vector<Block> RelaxedRotations(const PoseGraph& graph, const std::vector<bool>& anchored,
                                    const std::vector<Block>& rot,
                                    SharedCholesky* cholesky) {
  const size_t n = anchored.size();
  const bool planar = graph.dimension() == 2;
  const int d = planar ? 2 : 3;
  BlockSystem rs(anchored, d, d);
  rs.Reserve(graph.edges().size());
  std::vector<Block> known(n);
  for (size_t i = 0; i < n; ++i) known[i] = rot[i].transpose();
  const Block identity = Block::Identity(d, d);
  for (const Edge& e : graph.edges()) {
    if (!e.JoinsPoses()) continue;
    const size_t i = graph.VertexIndex(e.from), j = graph.VertexIndex(e.to);
    Block z;
    double w;
    if (planar) {
      z = ToSE2(e.z).rotation();
      w = e.information(2, 2);
    } else {
      z = ToSE3(e.z).rotation().toRotationMatrix();
      w = e.information.bottomRightCorner<3, 3>().trace() / 3.0;
    }
    rs.AddResidual(i, -z.transpose(), j, identity, Block::Zero(d, d), w * identity, known);
  }
  return rs.Solve(cholesky);
}

// The second stage: each free vertex's relaxed matrix back onto a rotation,
// by SVD in 3D, by normalising (cos, sin) in 2D.
void ProjectOntoRotations(const std::vector<Block>& relaxed, const std::vector<bool>& anchored,
                          bool planar, std::vector<Block>* rot) {
  for (size_t i = 0; i < anchored.size(); ++i) {
    if (anchored[i]) continue;
    const Block r = relaxed[i].transpose();
    if (planar) {
      const double theta = std::atan2(r(1, 0) - r(0, 1), r(0, 0) + r(1, 1));
      (*rot)[i] = SE2(0, 0, theta).rotation();
    } else {
      (*rot)[i] = NearestRotation(r);
    }
  }
}

// The last stage, translations with the rotations fixed: r = t_j - t_i -
// R_i t_z, weighed by (R_i R_z) Omega_t (R_i R_z)^T, the translation error's
// information. Free vertices' translations are replaced.
void SolveTranslations(const PoseGraph& graph, const std::vector<bool>& anchored,
                       const std::vector<Block>& rot, SharedCholesky* cholesky,
                       std::vector<Block>* trans) {
  const bool planar = graph.dimension() == 2;
  const int d = planar ? 2 : 3;
  BlockSystem ts(anchored, d, 1);
  ts.Reserve(graph.edges().size());
  const Block identity = Block::Identity(d, d);
  for (const Edge& e : graph.edges()) {
    if (!e.JoinsPoses()) continue;
    const size_t i = graph.VertexIndex(e.from), j = graph.VertexIndex(e.to);
    Block rz, tz;
    if (planar) {
      rz = ToSE2(e.z).rotation();
      tz = ToSE2(e.z).translation();
    } else {
      rz = ToSE3(e.z).rotation().toRotationMatrix();
      tz = ToSE3(e.z).translation();
    }
    const Block q = rot[i] * rz;
    const Block w = q * e.information.topLeftCorner(d, d) * q.transpose();
    ts.AddResidual(i, -identity, j, identity, rot[i] * tz, w, *trans);
  }
  const auto solved = ts.Solve(cholesky);
  for (size_t i = 0; i < anchored.size(); ++i)
    if (!anchored[i]) (*trans)[i] = solved[i];
}

}  // namespace

void InitializeBySpanningTree(PoseGraph& graph) { ChainAlongSpanningTree(graph); }

void InitializeByOdometry(PoseGraph& graph) {
  auto& vertices = graph.vertices();
  const std::vector<bool> root = ComponentRoots(graph);
  // Odometry adjacency by vertex index.
  std::vector<std::vector<size_t>> adj(vertices.size());
  const auto& edges = graph.edges();
  for (size_t k = 0; k < edges.size(); ++k) {
    if (edges[k].kind != EdgeKind::kOdometry) continue;
    adj[graph.VertexIndex(edges[k].from)].push_back(k);
    adj[graph.VertexIndex(edges[k].to)].push_back(k);
  }
  std::vector<bool> done(vertices.size(), false);
  for (size_t r = 0; r < vertices.size(); ++r) {
    if (!root[r]) continue;
    std::vector<size_t> stack{r};
    done[r] = true;
    while (!stack.empty()) {
      const size_t v = stack.back();
      stack.pop_back();
      for (size_t k : adj[v]) {
        const Edge& e = edges[k];
        const bool forward = graph.VertexIndex(e.from) == v;
        const size_t w = graph.VertexIndex(forward ? e.to : e.from);
        if (done[w]) continue;
        done[w] = true;
        if (!vertices[w].fixed) vertices[w].x = ChainMeasurement(graph, e, vertices[v].x, forward);
        stack.push_back(w);
      }
    }
  }
  PlaceLandmarks(graph);
}

void InitializeChordal(PoseGraph& graph) {
  auto& vertices = graph.vertices();
  const size_t n = vertices.size();
  const bool planar = graph.dimension() == 2;
  const std::vector<bool> root = ComponentRoots(graph);
  std::vector<bool> anchored(n);
  // Points take no part (PlaceLandmarks puts them in afterwards).
  for (size_t i = 0; i < n; ++i) anchored[i] = root[i] || vertices[i].fixed || vertices[i].landmark;

  // Current rotations and translations, as matrices.
  std::vector<Block> rot(n), trans(n);
  for (size_t i = 0; i < n; ++i) {
    if (vertices[i].landmark) continue;  // no edge of either stage touches one
    if (planar) {
      const SE2 p = ToSE2(vertices[i].x);
      rot[i] = p.rotation();
      trans[i] = p.translation();
    } else {
      const SE3 p = ToSE3(vertices[i].x);
      rot[i] = p.rotation().toRotationMatrix();
      trans[i] = p.translation();
    }
  }

  SharedCholesky cholesky;
  ProjectOntoRotations(RelaxedRotations(graph, anchored, rot, &cholesky), anchored, planar, &rot);
  SolveTranslations(graph, anchored, rot, &cholesky, &trans);

  for (size_t i = 0; i < n; ++i) {
    if (anchored[i]) continue;
    if (planar) {
      vertices[i].x = ToParams(SE2(trans[i](0), trans[i](1), std::atan2(rot[i](1, 0), rot[i](0, 0))));
    } else {
      const Eigen::Matrix3d r = rot[i];
      vertices[i].x = ToParams(SE3(Eigen::Quaterniond(r), Eigen::Vector3d(trans[i])));
    }
  }
  PlaceLandmarks(graph);
}

InitMethod ParseInitMethod(const std::string& name) {
  if (name == "file") return InitMethod::kFile;
  if (name == "odometry") return InitMethod::kOdometry;
  if (name == "spanning-tree") return InitMethod::kSpanningTree;
  if (name == "chordal") return InitMethod::kChordal;
  if (name == "auto") return InitMethod::kAuto;
  throw std::invalid_argument("unknown initialisation '" + name +
                              "' (file, odometry, spanning-tree, chordal or auto)");
}

const char* ToString(InitMethod method) {
  switch (method) {
    case InitMethod::kFile: return "file";
    case InitMethod::kOdometry: return "odometry";
    case InitMethod::kSpanningTree: return "spanning-tree";
    case InitMethod::kChordal: return "chordal";
    case InitMethod::kAuto: return "auto";
  }
  return "?";
}

namespace {

double CostOf(const PoseGraph& graph, const LoopClosureRho& rho) {
  if (!rho) return Chi2(graph);
  double sum = 0;
  for (const Edge& e : graph.edges()) {
    const double chi2 = EdgeChi2(graph, e);
    sum += e.kind == EdgeKind::kLoopClosure ? rho(chi2) : chi2;
  }
  return sum;
}

}  // namespace

InitReport InitializeAuto(PoseGraph& graph, const LoopClosureRho& rho) {
  const auto start = std::chrono::steady_clock::now();
  InitReport report;
  report.method = InitMethod::kAuto;
  report.file_chi2 = CostOf(graph, rho);
  std::vector<PoseParams> file;
  file.reserve(graph.vertices().size());
  for (const Vertex& v : graph.vertices()) file.push_back(v.x);
  try {
    InitializeChordal(graph);
    report.chordal_chi2 = CostOf(graph, rho);
  } catch (const std::runtime_error&) {
    report.chordal_chi2 = std::numeric_limits<double>::quiet_NaN();
  }
  // A NaN file chi2 loses to any finite chordal one.
  const bool chordal = report.chordal_chi2 < report.file_chi2 ||
                       (!std::isfinite(report.file_chi2) && std::isfinite(report.chordal_chi2));
  if (!chordal) {
    size_t k = 0;
    for (Vertex& v : graph.vertices()) v.x = file[k++];
  }
  report.chosen = chordal ? InitMethod::kChordal : InitMethod::kFile;
  report.robust_cost = static_cast<bool>(rho);
  report.chi2 = rho ? Chi2(graph) : chordal ? report.chordal_chi2 : report.file_chi2;
  report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

std::string DescribeAutoChoice(const InitReport& report) {
  const bool chordal = report.chosen == InitMethod::kChordal;
  char buf[200];
  if (std::isnan(report.chordal_chi2)) {
    std::snprintf(buf, sizeof buf, "initial estimate (auto): file, %s %.10g (chordal: singular)",
                  report.robust_cost ? "robust cost" : "chi2", report.file_chi2);
  } else if (report.robust_cost) {
    std::snprintf(buf, sizeof buf,
                  "initial estimate (auto): %s, robust cost %.10g (%s %.10g), chi2 %.10g",
                  ToString(report.chosen), chordal ? report.chordal_chi2 : report.file_chi2,
                  chordal ? "file" : "chordal", chordal ? report.file_chi2 : report.chordal_chi2,
                  report.chi2);
  } else {
    std::snprintf(buf, sizeof buf, "initial estimate (auto): %s, chi2 %.10g (%s %.10g)",
                  ToString(report.chosen), report.chi2, chordal ? "file" : "chordal",
                  chordal ? report.file_chi2 : report.chordal_chi2);
  }
  return buf;
}

InitReport Initialize(PoseGraph& graph, InitMethod method, const LoopClosureRho& rho) {
  if (method == InitMethod::kAuto) return InitializeAuto(graph, rho);
  const auto start = std::chrono::steady_clock::now();
  switch (method) {
    case InitMethod::kAuto: break;  // above
    case InitMethod::kFile: break;
    case InitMethod::kOdometry: InitializeByOdometry(graph); break;
    case InitMethod::kSpanningTree: InitializeBySpanningTree(graph); break;
    case InitMethod::kChordal: InitializeChordal(graph); break;
  }
  InitReport report;
  report.method = report.chosen = method;
  report.time_s = Seconds(start);
  report.chi2 = Chi2(graph);
  return report;
}

}  // namespace cairn
