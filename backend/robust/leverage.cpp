#include "cairn/robust/leverage.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "cairn/linear/block_cholesky.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
namespace {

struct Linearized {
  Eigen::VectorXd r;
  std::vector<Eigen::MatrixXd> jac;
};

Linearized Linearize(const PoseGraph& graph, const Edge& edge, const ceres::Manifold& manifold) {
  LinearizedEdge lin = LinearizeEdge(graph, edge, manifold);
  return Linearized{std::move(lin.residual), std::move(lin.jacobians)};
}

// The normal matrix H = sum J^T J of the whole graph over the poses not
// held for the gauge (d columns each), factorised: what both statistics
// below read the poses' covariances from.
class NormalEquations {
 public:
  explicit NormalEquations(const PoseGraph& graph)
      : graph_(graph),
        d_(graph.TangentSize()),
        manifold_(graph.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold()) {
    const std::vector<bool> held = HeldConstant(graph), touched = TouchedVertices(graph);
    block_.assign(graph.vertices().size(), -1);
    int blocks = 0;
    for (size_t v = 0; v < block_.size(); ++v)
      if (touched[v] && !held[v]) block_[v] = blocks++;
    if (blocks == 0) return;
    BlockMatrix h(blocks, d_);
    for (const Edge& e : graph.edges()) {
      const Linearized lin = Linearize(graph, e, *manifold_);
      const int o[2] = {Block(e.from), e.IsPrior() ? -1 : Block(e.to)};
      for (size_t a = 0; a < lin.jac.size(); ++a)
        for (size_t b = 0; b <= a; ++b)
          if (o[a] >= 0 && o[b] >= 0) h.Add(o[a], o[b], lin.jac[a].transpose() * lin.jac[b]);
    }
    factor_ = BlockCholesky::Factorize(h);
  }

  bool empty() const { return factor_ == nullptr; }
  BlockCholesky& factor() const { return *factor_; }

  // A between-edge's residual and its Jacobian restricted to its variable
  // poses (d x m, m = d or 2d), with those poses' blocks of H.
  Linearized Restricted(const Edge& e, Eigen::MatrixXd* J, std::vector<int>* blocks) const {
    Linearized lin = Linearize(graph_, e, *manifold_);
    J->resize(d_, 2 * d_);
    blocks->clear();
    for (int a = 0; a < 2; ++a) {
      const int o = Block(a == 0 ? e.from : e.to);
      if (o < 0) continue;
      J->middleCols(d_ * static_cast<int>(blocks->size()), d_) = lin.jac[a];
      blocks->push_back(o);
    }
    J->conservativeResize(d_, d_ * static_cast<int>(blocks->size()));
    return lin;
  }

  // Sigma over a few poses' blocks (from the selected inverse).
  Eigen::MatrixXd Covariance(const std::vector<int>& blocks) const {
    const int m = static_cast<int>(blocks.size());
    Eigen::MatrixXd s(d_ * m, d_ * m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j <= i; ++j) {
        s.block(d_ * i, d_ * j, d_, d_) = factor_->Inverse(blocks[i], blocks[j]);
        if (i != j) s.block(d_ * j, d_ * i, d_, d_) = s.block(d_ * i, d_ * j, d_, d_).transpose();
      }
    return s;
  }

  // A pose's block of H, -1 when it is held.
  int Block(int64_t id) const { return block_[graph_.VertexIndex(id)]; }

 private:
  const PoseGraph& graph_;
  int d_;
  std::unique_ptr<ceres::Manifold> manifold_;
  std::vector<int> block_;  // per vertex index, -1 when held
  std::unique_ptr<BlockCholesky> factor_;
};

// A group of edges linearised together: stacked whitened residuals and
// Jacobians over the blocks of H of the poses the group touches (ascending).
struct StackedGroup {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  std::vector<int> blocks;
};

StackedGroup Stack(const PoseGraph& graph, const NormalEquations& normal,
                   const std::vector<size_t>& group) {
  const int d = graph.TangentSize();
  StackedGroup g;
  for (size_t k : group)
    for (int64_t v : {graph.edges().at(k).from, graph.edges().at(k).to})
      if (normal.Block(v) >= 0) g.blocks.push_back(normal.Block(v));
  std::sort(g.blocks.begin(), g.blocks.end());
  g.blocks.erase(std::unique(g.blocks.begin(), g.blocks.end()), g.blocks.end());
  const int rows = d * static_cast<int>(group.size());
  g.r.resize(rows);
  g.J = Eigen::MatrixXd::Zero(rows, d * static_cast<Eigen::Index>(g.blocks.size()));
  Eigen::MatrixXd J;
  std::vector<int> blocks;
  for (size_t k = 0; k < group.size(); ++k) {
    const Edge& e = graph.edges().at(group[k]);
    if (e.IsPrior())
      throw std::invalid_argument("GroupDeletedResidualChi2: a prior is no between-edge");
    g.r.segment(d * k, d) = normal.Restricted(e, &J, &blocks).r;
    for (size_t c = 0; c < blocks.size(); ++c) {
      const auto at = std::lower_bound(g.blocks.begin(), g.blocks.end(), blocks[c]) - g.blocks.begin();
      g.J.block(d * k, d * at, d, d) = J.middleCols(d * c, d);
    }
  }
  return g;
}

// r^T M^{-1} r for M = I - J Sigma J^T; NaN when M is singular (the edges
// alone decide a direction: 1 - leverage near 0). M's eigenvalues lie in
// (0, 1], so the reciprocal condition number estimates the smallest; a
// Cholesky factor and its estimate cost a twenty-fifth of the eigenvalues
// that were computed here (a third of the run verification on
// parking-garage, whose runs stack up to 384 rows).
double DeletedChi2(const Eigen::MatrixXd& M, const Eigen::VectorXd& r) {
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success || !(llt.rcond() >= 1e-9))
    return std::numeric_limits<double>::quiet_NaN();
  return r.dot(llt.solve(r));
}

}  // namespace

std::vector<double> DeletedResidualChi2(const PoseGraph& graph, const std::vector<size_t>& edges) {
  RequireNoLandmarks(graph, "the deleted-residual test");
  std::vector<double> out(edges.size(), std::numeric_limits<double>::quiet_NaN());
  const NormalEquations normal(graph);
  if (normal.empty()) return out;
  const int d = graph.TangentSize();
  Eigen::MatrixXd J;
  std::vector<int> blocks;
  for (size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = graph.edges()[edges[k]];
    if (e.IsPrior()) throw std::invalid_argument("DeletedResidualChi2: a prior is no between-edge");
    // J restricted to the variable poses, and those poses' joint covariance.
    const Linearized lin = normal.Restricted(e, &J, &blocks);
    const Eigen::MatrixXd S = normal.Covariance(blocks);
    out[k] = DeletedChi2(Eigen::MatrixXd::Identity(d, d) - J * S * J.transpose(), lin.r);
  }
  return out;
}

namespace {

// A lower bound on r^T (I + J S J^T)^{-1} r from S's diagonal blocks alone
// (one per pose, on the factor's pattern): S <= 2 diag(S_aa, S_bb), since
// S with its off-diagonal blocks negated is positive semi-definite too.
double InnovationLowerBound(const NormalEquations& normal, const Linearized& lin,
                            const Eigen::MatrixXd& J, const std::vector<int>& blocks, int d) {
  Eigen::MatrixXd upper = Eigen::MatrixXd::Identity(d, d);
  for (size_t p = 0; p < blocks.size(); ++p) {
    const Eigen::MatrixXd jp = J.middleCols(d * p, d);
    upper += (blocks.size() > 1 ? 2.0 : 1.0) * jp * normal.factor().Inverse(blocks[p], blocks[p]) *
             jp.transpose();
  }
  return lin.r.dot(upper.ldlt().solve(lin.r));
}

}  // namespace

std::vector<double> GroupDeletedResidualChi2(const PoseGraph& graph,
                                             const std::vector<std::vector<size_t>>& groups) {
  RequireNoLandmarks(graph, "the deleted-residual test");
  std::vector<double> out(groups.size(), std::numeric_limits<double>::quiet_NaN());
  const NormalEquations normal(graph);
  if (normal.empty()) return out;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].empty()) continue;
    const StackedGroup stacked = Stack(graph, normal, groups[g]);
    const Eigen::Index rows = stacked.r.size();
    Eigen::MatrixXd M = Eigen::MatrixXd::Identity(rows, rows);
    if (!stacked.blocks.empty()) M -= normal.factor().Gram(stacked.blocks, stacked.J.transpose());
    out[g] = DeletedChi2(M, stacked.r);
  }
  return out;
}

std::vector<InnovationStat> InnovationChi2(const PoseGraph& graph, const std::vector<Edge>& candidates,
                                           double screen) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  RequireNoLandmarks(graph, "the innovation test");
  std::vector<InnovationStat> out(candidates.size(), InnovationStat{nan, nan});
  const NormalEquations normal(graph);
  const int d = graph.TangentSize();
  if (normal.empty()) return out;
  Eigen::MatrixXd J;
  std::vector<int> blocks;
  for (size_t k = 0; k < candidates.size(); ++k) {
    const Linearized lin = normal.Restricted(candidates[k], &J, &blocks);
    if (std::isfinite(screen)) {
      const double low = InnovationLowerBound(normal, lin, J, blocks, d);
      if (low > screen) {
        out[k] = InnovationStat{low, nan, false};
        continue;
      }
    }
    // The two poses' joint covariance, J Sigma J^T by forward solves.
    const Eigen::MatrixXd P = normal.factor().Gram(blocks, J.transpose());
    const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(d, d) + P;
    out[k].chi2 = lin.r.dot(M.ldlt().solve(lin.r));
    out[k].spread = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().maxCoeff();
  }
  return out;
}

}  // namespace cairn
