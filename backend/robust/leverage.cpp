#include "cairn/robust/leverage.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Linearized {
  Eigen::VectorXd r;
  std::vector<Eigen::MatrixXd> jac;
};

Linearized Linearize(const PoseGraph& graph, const Edge& edge, const ceres::Manifold& manifold) {
  LinearizedEdge lin = LinearizeEdge(graph, edge, manifold);
  return Linearized{std::move(lin.residual), std::move(lin.jacobians)};
}

// The entries of A^{-1} on the pattern of A's Cholesky factor L (lower,
// column-major, diagonal first in each column, rows ascending), by
// Takahashi's recurrence from the last column back:
//   Z_ij = -(1/L_jj) sum_{k>j} Z_ik L_kj   (i > j)
//   Z_jj = (1/L_jj - sum_{k>j} Z_kj L_kj) / L_jj
// Every Z_ik it needs lies on the pattern (the factor's pattern is chordal).
class SelectedInverse {
 public:
  explicit SelectedInverse(const Eigen::SparseMatrix<double>& L)
      : n_(static_cast<int>(L.cols())),
        col_(L.outerIndexPtr(), L.outerIndexPtr() + L.cols() + 1),
        row_(L.innerIndexPtr(), L.innerIndexPtr() + L.nonZeros()),
        z_(L.nonZeros(), 0.0) {
    const double* l = L.valuePtr();
    for (int j = 0; j < n_; ++j)
      if (col_[j] == col_[j + 1] || row_[col_[j]] != j ||
          !std::is_sorted(row_.begin() + col_[j], row_.begin() + col_[j + 1]))
        throw std::runtime_error("unexpected layout of the Cholesky factor");
    std::vector<double> sum(n_, 0.0);
    for (int j = n_ - 1; j >= 0; --j) {
      const int p0 = col_[j], p1 = col_[j + 1];
      const double ljj = l[p0];
      for (int a = p0 + 1; a < p1; ++a) sum[a - p0] = 0;
      for (int b = p0 + 1; b < p1; ++b) AddColumnTerms(j, b, l, &sum);
      for (int a = p0 + 1; a < p1; ++a) z_[a] = -sum[a - p0] / ljj;
      double s = 0;
      for (int a = p0 + 1; a < p1; ++a) s += z_[a] * l[a];
      z_[p0] = (1 / ljj - s) / ljj;
    }
  }

  // The terms of column j's sums (sum[a - col_[j]] for its entry a) that
  // column k = row b of it holds: for each entry a of column j with row
  // i >= k, Z_ik l_b to a's sum and, when i > k, Z_ik l_a to b's (Z is
  // symmetric). Over every b of column j that is each Z_ik L_kj once. Rows
  // of column j at or below k are rows of column k (chordal pattern): one
  // merge of the two sorted columns, no search.
  void AddColumnTerms(int j, int b, const double* l, std::vector<double>* sum) const {
    const int p0 = col_[j], p1 = col_[j + 1], k = row_[b];
    int q = col_[k];
    const int q1 = col_[k + 1];
    for (int a = b; a < p1; ++a) {
      const int i = row_[a];
      while (q < q1 && row_[q] < i) ++q;
      if (q == q1 || row_[q] != i) throw std::logic_error("selected inverse: entry off the pattern");
      (*sum)[a - p0] += z_[q] * l[b];
      if (a != b) (*sum)[b - p0] += z_[q] * l[a];
    }
  }

  // Sigma's block over the original unknowns cols[0..m) (symmetric), for a
  // factor of P H P^T: Sigma(p, q) = Z(perm[p], perm[q]).
  Eigen::MatrixXd Block(const Eigen::VectorXi& perm, const int* cols, int m) const {
    Eigen::MatrixXd b(m, m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j <= i; ++j) b(i, j) = b(j, i) = At(perm[cols[i]], perm[cols[j]]);
    return b;
  }

  // Z_ik for a pair on the pattern (either order).
  double At(int i, int k) const {
    if (i < k) std::swap(i, k);
    const auto begin = row_.begin() + col_[k], end = row_.begin() + col_[k + 1];
    const auto it = std::lower_bound(begin, end, i);
    if (it == end || *it != i) throw std::logic_error("selected inverse: entry off the pattern");
    return z_[it - row_.begin()];
  }

 private:
  int n_;
  std::vector<int> col_, row_;
  std::vector<double> z_;
};

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
    offset_.assign(graph.vertices().size(), -1);
    for (size_t v = 0; v < offset_.size(); ++v)
      if (touched[v] && !held[v]) {
        offset_[v] = n_;
        n_ += d_;
      }
    if (n_ == 0) return;
    // Lower triangle.
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(graph.edges().size() * 4 * d_ * d_);
    for (const Edge& e : graph.edges()) {
      const Linearized lin = Linearize(graph, e, *manifold_);
      const int o[2] = {Offset(e.from), e.IsPrior() ? -1 : Offset(e.to)};
      for (size_t a = 0; a < lin.jac.size(); ++a) {
        if (o[a] < 0) continue;
        for (size_t b = 0; b < lin.jac.size(); ++b) {
          if (o[b] < 0 || o[b] > o[a]) continue;
          const Eigen::MatrixXd h = lin.jac[a].transpose() * lin.jac[b];
          for (int i = 0; i < d_; ++i)
            for (int j = 0; j < d_; ++j)
              if (o[a] + i >= o[b] + j) triplets.emplace_back(o[a] + i, o[b] + j, h(i, j));
        }
      }
    }
    Eigen::SparseMatrix<double> H(n_, n_);
    H.setFromTriplets(triplets.begin(), triplets.end());
    llt_.compute(H);
    if (llt_.info() != Eigen::Success)
      throw std::runtime_error("the information matrix is not positive definite");
  }

  int size() const { return n_; }
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower>& llt() const { return llt_; }

  // A between-edge's residual and its Jacobian restricted to its variable
  // poses (d x m, m = d or 2d), with the columns of H those poses take.
  Linearized Restricted(const Edge& e, Eigen::MatrixXd* J, std::vector<int>* cols) const {
    Linearized lin = Linearize(graph_, e, *manifold_);
    J->resize(d_, 2 * d_);
    cols->clear();
    int m = 0;
    for (int a = 0; a < 2; ++a) {
      const int o = Offset(a == 0 ? e.from : e.to);
      if (o < 0) continue;
      J->middleCols(m, d_) = lin.jac[a];
      for (int i = 0; i < d_; ++i) cols->push_back(o + i);
      m += d_;
    }
    J->conservativeResize(d_, m);
    return lin;
  }

  // The first column of a pose in H, -1 when it is held.
  int Offset(int64_t id) const { return offset_[graph_.VertexIndex(id)]; }

 private:
  const PoseGraph& graph_;
  int d_, n_ = 0;
  std::unique_ptr<ceres::Manifold> manifold_;
  std::vector<int> offset_;  // per vertex index: first column in H, -1 when held
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt_;
};

// A group of edges linearised together: stacked whitened residuals and
// Jacobians over the columns `cols` of H (d per pose the group touches,
// ascending).
struct StackedGroup {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  std::vector<int> cols;
};

StackedGroup Stack(const PoseGraph& graph, const NormalEquations& normal,
                   const std::vector<size_t>& group) {
  const int d = graph.TangentSize();
  std::vector<int> first;  // each pose's first column
  for (size_t k : group)
    for (int64_t v : {graph.edges().at(k).from, graph.edges().at(k).to})
      if (normal.Offset(v) >= 0) first.push_back(normal.Offset(v));
  std::sort(first.begin(), first.end());
  first.erase(std::unique(first.begin(), first.end()), first.end());
  StackedGroup g;
  for (int f : first)
    for (int i = 0; i < d; ++i) g.cols.push_back(f + i);
  const int rows = d * static_cast<int>(group.size());
  g.r.resize(rows);
  g.J = Eigen::MatrixXd::Zero(rows, static_cast<Eigen::Index>(g.cols.size()));
  Eigen::MatrixXd J;
  std::vector<int> cols;
  for (size_t k = 0; k < group.size(); ++k) {
    const Edge& e = graph.edges().at(group[k]);
    if (e.IsPrior())
      throw std::invalid_argument("GroupDeletedResidualChi2: a prior is no between-edge");
    g.r.segment(d * k, d) = normal.Restricted(e, &J, &cols).r;
    for (size_t c = 0; c < cols.size(); c += d) {
      const auto at = std::lower_bound(first.begin(), first.end(), cols[c]) - first.begin();
      g.J.block(d * k, d * at, d, d) = J.middleCols(c, d);
    }
  }
  return g;
}

// r^T M^{-1} r for M = I - J Sigma J^T; NaN when M is singular (the edges
// alone decide a direction: 1 - leverage near 0).
double DeletedChi2(const Eigen::MatrixXd& M, const Eigen::VectorXd& r) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(M);
  if (eig.info() != Eigen::Success || eig.eigenvalues().minCoeff() < 1e-9)
    return std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd u = eig.eigenvectors().transpose() * r;
  return (u.array().square() / eig.eigenvalues().array()).sum();
}

}  // namespace

std::vector<double> DeletedResidualChi2(const PoseGraph& graph, const std::vector<size_t>& edges) {
  RequireNoLandmarks(graph, "the deleted-residual test");
  std::vector<double> out(edges.size(), std::numeric_limits<double>::quiet_NaN());
  const NormalEquations normal(graph);
  if (normal.size() == 0) return out;
  const int d = graph.TangentSize();
  const Eigen::SparseMatrix<double> L = normal.llt().matrixL().nestedExpression();
  const SelectedInverse z(L);
  const Eigen::VectorXi perm = normal.llt().permutationP().indices();
  Eigen::MatrixXd J;
  std::vector<int> cols;
  for (size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = graph.edges()[edges[k]];
    if (e.IsPrior()) throw std::invalid_argument("DeletedResidualChi2: a prior is no between-edge");
    // J restricted to the variable poses, and those poses' joint covariance.
    const Linearized lin = normal.Restricted(e, &J, &cols);
    const Eigen::MatrixXd S = z.Block(perm, cols.data(), static_cast<int>(cols.size()));
    out[k] = DeletedChi2(Eigen::MatrixXd::Identity(d, d) - J * S * J.transpose(), lin.r);
  }
  return out;
}

namespace {

// Columns of L^{-1} P E for a few unit columns E (original unknowns
// `cols`), P H P^T = L L^T: their joint covariance is the Gram matrix
// of these. A unit vector's forward solve touches only its column's
// ancestors in the elimination tree (the rows of a factor's column are
// ancestors of it), so each solve walks those paths, not all of L.
class ForwardSolves {
 public:
  ForwardSolves(const Eigen::SparseMatrix<double>& L, const Eigen::VectorXi& perm)
      : l_(L), perm_(perm), pos_(L.cols(), -1) {}

  // S = (L^{-1} P E)^T (L^{-1} P E).
  Eigen::MatrixXd Covariance(const std::vector<int>& cols) {
    const auto m = static_cast<Eigen::Index>(cols.size());
    return Gram(cols, Eigen::MatrixXd::Identity(m, m));
  }

  // (L^{-1} P B)^T (L^{-1} P B) = B^T Sigma B for a B whose rows are the
  // original unknowns `cols` (zero elsewhere): B = E gives their
  // covariance, B = J^T the projection J Sigma J^T of a few rows'
  // Jacobian. Rows of the solves are updated whole, across B's columns.
  Eigen::MatrixXd Gram(const std::vector<int>& cols, const Eigen::MatrixXd& B) {
    const int* cp = l_.outerIndexPtr();
    const int* ri = l_.innerIndexPtr();
    const double* lx = l_.valuePtr();
    reach_.clear();
    for (int c : cols)
      for (int j = perm_[c]; j >= 0 && pos_[j] < 0; j = cp[j + 1] - cp[j] > 1 ? ri[cp[j] + 1] : -1) {
        pos_[j] = 0;
        reach_.push_back(j);
      }
    std::sort(reach_.begin(), reach_.end());
    for (size_t t = 0; t < reach_.size(); ++t) pos_[reach_[t]] = static_cast<int>(t);
    RowMajor y = RowMajor::Zero(static_cast<Eigen::Index>(reach_.size()), B.cols());
    for (size_t c = 0; c < cols.size(); ++c) y.row(pos_[perm_[cols[c]]]) = B.row(c);
    for (int j : reach_) {
      const int pj = pos_[j];
      y.row(pj) /= lx[cp[j]];
      for (int q = cp[j] + 1; q < cp[j + 1]; ++q) y.row(pos_[ri[q]]) -= lx[q] * y.row(pj);
    }
    for (int j : reach_) pos_[j] = -1;
    return y.transpose() * y;
  }

 private:
  const Eigen::SparseMatrix<double>& l_;
  const Eigen::VectorXi& perm_;
  std::vector<int> pos_;    // per column of L: its place in reach_, -1 when not there
  std::vector<int> reach_;  // the columns the solves touch, ascending
};

// A lower bound on r^T (I + J S J^T)^{-1} r from S's diagonal blocks alone
// (one per pose, on the factor's pattern): S <= 2 diag(S_aa, S_bb), since
// S with its off-diagonal blocks negated is positive semi-definite too.
double InnovationLowerBound(const SelectedInverse& z, const Eigen::VectorXi& perm,
                            const Linearized& lin, const Eigen::MatrixXd& J,
                            const std::vector<int>& cols, int d) {
  const int poses = static_cast<int>(cols.size()) / d;
  Eigen::MatrixXd upper = Eigen::MatrixXd::Identity(d, d);
  for (int p = 0; p < poses; ++p) {
    const Eigen::MatrixXd jp = J.middleCols(p * d, d);
    upper += (poses > 1 ? 2.0 : 1.0) * jp * z.Block(perm, cols.data() + p * d, d) * jp.transpose();
  }
  return lin.r.dot(upper.ldlt().solve(lin.r));
}

}  // namespace

std::vector<double> GroupDeletedResidualChi2(const PoseGraph& graph,
                                             const std::vector<std::vector<size_t>>& groups) {
  RequireNoLandmarks(graph, "the deleted-residual test");
  std::vector<double> out(groups.size(), std::numeric_limits<double>::quiet_NaN());
  const NormalEquations normal(graph);
  if (normal.size() == 0) return out;
  const Eigen::SparseMatrix<double> L = normal.llt().matrixL().nestedExpression();
  const Eigen::VectorXi perm = normal.llt().permutationP().indices();
  ForwardSolves solves(L, perm);
  for (size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].empty()) continue;
    const StackedGroup stacked = Stack(graph, normal, groups[g]);
    const Eigen::Index rows = stacked.r.size();
    Eigen::MatrixXd M = Eigen::MatrixXd::Identity(rows, rows);
    if (!stacked.cols.empty()) M -= solves.Gram(stacked.cols, stacked.J.transpose());
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
  const int n = normal.size(), d = graph.TangentSize();
  if (n == 0) return out;
  const Eigen::SparseMatrix<double> L = normal.llt().matrixL().nestedExpression();
  const Eigen::VectorXi perm = normal.llt().permutationP().indices();
  ForwardSolves solves(L, perm);
  std::unique_ptr<SelectedInverse> z;
  if (std::isfinite(screen)) z = std::make_unique<SelectedInverse>(L);
  Eigen::MatrixXd J;
  std::vector<int> cols;
  for (size_t k = 0; k < candidates.size(); ++k) {
    const Linearized lin = normal.Restricted(candidates[k], &J, &cols);
    if (z) {
      const double low = InnovationLowerBound(*z, perm, lin, J, cols, d);
      if (low > screen) {
        out[k] = InnovationStat{low, nan, false};
        continue;
      }
    }
    // The two poses' joint covariance.
    const Eigen::MatrixXd S = solves.Covariance(cols);
    const Eigen::MatrixXd P = J * S * J.transpose();
    const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(d, d) + P;
    out[k].chi2 = lin.r.dot(M.ldlt().solve(lin.r));
    out[k].spread = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().maxCoeff();
  }
  return out;
}

}  // namespace cairn
