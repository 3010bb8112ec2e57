#include "cairn/linear/conjugate_gradients.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholmod_common.h"

namespace cairn {
namespace {

// The scalar unknowns split into the caller's blocks (or one block each).
struct Blocks {
  std::vector<int> first;  // first unknown of each block, then n
  std::vector<int> of;     // block of each unknown
  int count() const { return static_cast<int>(first.size()) - 1; }
  int size(int b) const { return first[b + 1] - first[b]; }
};

Blocks MakeBlocks(int n, const std::vector<int>& block_sizes) {
  Blocks blocks;
  blocks.first.push_back(0);
  if (block_sizes.empty()) {
    for (int i = 0; i < n; ++i) blocks.first.push_back(i + 1);
  } else {
    for (int s : block_sizes) blocks.first.push_back(blocks.first.back() + s);
  }
  if (blocks.first.back() != n) throw std::invalid_argument("block sizes do not add up to n");
  blocks.of.resize(n);
  for (int b = 0; b < blocks.count(); ++b)
    for (int i = blocks.first[b]; i < blocks.first[b + 1]; ++i) blocks.of[i] = b;
  return blocks;
}

// Union-find for Kruskal's algorithm.
struct Forest {
  explicit Forest(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int Root(int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  bool Join(int a, int b) {
    a = Root(a), b = Root(b);
    if (a == b) return false;
    parent[a] = b;
    return true;
  }
  std::vector<int> parent;
};

// H's off-diagonal blocks as the edges of its block graph: each pair's
// coupling relative to its two diagonal blocks (the spanning tree's weight)
// and, per entry of H, its pair (-1 within a diagonal block).
struct Couplings {
  std::vector<std::pair<int, int>> pairs;  // (row block, column block), row < column
  std::vector<double> weight;
  std::vector<int> pair_of;
};

Couplings BlockCouplings(const Blocks& blocks, const std::vector<int>& col_ptr,
                         const std::vector<int>& rows, const std::vector<double>& values) {
  const int nb = blocks.count();
  Couplings c;
  std::vector<double> diag_norm(nb, 0.0), pair_norm;
  c.pair_of.assign(values.size(), -1);
  std::vector<int> pair_in_column(nb, -1);  // for the current column block
  for (int bj = 0; bj < nb; ++bj) {
    const size_t column_pairs = c.pairs.size();
    for (int j = blocks.first[bj]; j < blocks.first[bj + 1]; ++j)
      for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) {
        const int bi = blocks.of[rows[k]];
        const double v2 = values[k] * values[k];
        if (bi == bj) {
          diag_norm[bj] += v2;
          continue;
        }
        if (pair_in_column[bi] < 0) {
          pair_in_column[bi] = static_cast<int>(c.pairs.size());
          c.pairs.emplace_back(bi, bj);
          pair_norm.push_back(0.0);
        }
        c.pair_of[k] = pair_in_column[bi];
        pair_norm[c.pair_of[k]] += v2;
      }
    for (size_t p = column_pairs; p < c.pairs.size(); ++p) pair_in_column[c.pairs[p].first] = -1;
  }
  c.weight.resize(c.pairs.size());
  for (size_t p = 0; p < c.pairs.size(); ++p)
    c.weight[p] = std::sqrt(pair_norm[p] / std::max(std::sqrt(diag_norm[c.pairs[p].first] *
                                                              diag_norm[c.pairs[p].second]),
                                                    std::numeric_limits<double>::min()));
  return c;
}

// The pairs by weight, heaviest first; Kruskal takes them into the tree.
std::vector<int> HeaviestFirst(const Couplings& c) {
  std::vector<int> order(c.pairs.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return c.weight[a] > c.weight[b]; });
  return order;
}

// Nonzeros of the Cholesky factor of the block graph with the pairs marked
// `in` (CHOLMOD's AMD analysis, blocks counted as one entry each).
double BlockFactorNonZeros(const Blocks& blocks, const Couplings& c, const std::vector<bool>& in,
                           CholmodCommon& cholmod) {
  const int nb = blocks.count();
  std::vector<std::vector<int>> above(nb);
  for (size_t p = 0; p < c.pairs.size(); ++p)
    if (in[p]) above[c.pairs[p].second].push_back(c.pairs[p].first);
  BlockPattern pattern;
  pattern.first = blocks.first;
  pattern.bp.push_back(0);
  for (int b = 0; b < nb; ++b) {
    std::sort(above[b].begin(), above[b].end());
    pattern.bi.insert(pattern.bi.end(), above[b].begin(), above[b].end());
    pattern.bi.push_back(b);
    pattern.bp.push_back(static_cast<int>(pattern.bi.size()));
  }
  cholmod_sparse* graph = BlockGraph(pattern, cholmod.get());
  if (!graph) return std::numeric_limits<double>::infinity();
  cholmod_factor* f = cholmod_analyze(graph, cholmod.get());
  const double lnz = f ? cholmod->lnz : std::numeric_limits<double>::infinity();
  if (f) cholmod_free_factor(&f, cholmod.get());
  cholmod_free_sparse(&graph, cholmod.get());
  return lnz;
}

// Into the tree `in`, the heaviest other pairs, as many as keep the block
// factor within `budget`: the longest such prefix of `order`, by bisection
// (AMD's fill is not quite monotone in the prefix; close enough for a
// budget). Returns how many were added.
size_t AddWithinBudget(const Blocks& blocks, const Couplings& c, const std::vector<int>& order,
                       double budget, std::vector<bool>* in) {
  std::vector<int> others;
  for (int p : order)
    if (!(*in)[p]) others.push_back(p);
  CholmodCommon cholmod;
  auto with = [&](size_t m) {
    std::vector<bool> trial = *in;
    for (size_t k = 0; k < m; ++k) trial[others[k]] = true;
    return trial;
  };
  size_t lo = 0, hi = others.size();
  if (BlockFactorNonZeros(blocks, c, with(hi), cholmod) > budget) {
    while (hi - lo > 1) {
      const size_t mid = lo + (hi - lo) / 2;
      (BlockFactorNonZeros(blocks, c, with(mid), cholmod) <= budget ? lo : hi) = mid;
    }
    hi = lo;
  }
  *in = with(hi);
  return hi;
}

class ConjugateGradients final : public SparseCholesky {
 public:
  explicit ConjugateGradients(const ConjugateGradientsOptions& o) : options_(o) {}

  void Analyze(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
               const std::vector<int>& block_sizes) override {
    n_ = n;
    col_ptr_ = col_ptr;
    rows_ = rows;
    values_.assign(rows.size(), 0.0);
    blocks_ = MakeBlocks(n, block_sizes);
    block_sizes_ = block_sizes;
    subgraph_.reset();
    use_subgraph_ = options_.preconditioner != Preconditioner::kBlockJacobi;
  }

  double* values() override { return values_.data(); }

  bool Factorize() override {
    if (!FactorDiagonalBlocks()) return false;
    if (!use_subgraph_) return true;
    if (!subgraph_) ChooseSubgraph();
    double* v = subgraph_->values();
    for (size_t k = 0; k < subgraph_source_.size(); ++k) v[k] = values_[subgraph_source_[k]];
    // Not positive definite only when a residual joins three or more blocks.
    if (!subgraph_->Factorize()) use_subgraph_ = false;
    return true;
  }

  void Solve(const double* b, double* x) override;

  long FactorNonZeros() const override {
    if (use_subgraph_ && subgraph_) return subgraph_->FactorNonZeros();
    long nz = 0;
    for (int b = 0; b < blocks_.count(); ++b) nz += blocks_.size(b) * (blocks_.size(b) + 1) / 2;
    return nz;
  }
  bool IsSupernodal() const override { return false; }
  std::string Method() const override {
    if (!use_subgraph_) return "conjugate gradients, block-Jacobi preconditioner";
    if (options_.preconditioner == Preconditioner::kSpanningTree)
      return "conjugate gradients, spanning-tree preconditioner";
    return "conjugate gradients, subgraph preconditioner (spanning tree and " +
           std::to_string(extra_pairs_) + " of " + std::to_string(other_pairs_) +
           " other blocks)";
  }

 private:
  bool FactorDiagonalBlocks();
  void ChooseSubgraph();
  void Multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
  void Precondition(const Eigen::VectorXd& r, Eigen::VectorXd* z) const;

  const ConjugateGradientsOptions options_;
  int n_ = 0;
  std::vector<int> col_ptr_, rows_, block_sizes_;
  std::vector<double> values_;
  Blocks blocks_;
  std::vector<Eigen::LLT<Eigen::MatrixXd>> diagonal_;
  bool use_subgraph_ = true;
  std::unique_ptr<SparseCholesky> subgraph_;  // H on the subgraph's pattern
  std::vector<int> subgraph_source_;          // for each of its entries, its index in values_
  size_t extra_pairs_ = 0, other_pairs_ = 0;
};

bool ConjugateGradients::FactorDiagonalBlocks() {
  const int nb = blocks_.count();
  diagonal_.resize(nb);
  std::vector<Eigen::MatrixXd> d(nb);
  for (int b = 0; b < nb; ++b) d[b].setZero(blocks_.size(b), blocks_.size(b));
  for (int j = 0; j < n_; ++j) {
    const int bj = blocks_.of[j];
    for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k) {
      const int i = rows_[k];
      if (blocks_.of[i] != bj) continue;
      const int li = i - blocks_.first[bj], lj = j - blocks_.first[bj];
      d[bj](li, lj) = d[bj](lj, li) = values_[k];
    }
  }
  for (int b = 0; b < nb; ++b) {
    diagonal_[b].compute(d[b]);
    if (diagonal_[b].info() != Eigen::Success) return false;
  }
  return true;
}

// Kruskal on the block graph, heaviest relative coupling first, then (for
// kSubgraph) the heaviest other pairs within the budget; the subgraph's
// pattern (whole diagonal blocks and the chosen off-diagonal ones) and its
// analysis, once: later factorisations refill it.
void ConjugateGradients::ChooseSubgraph() {
  const int nb = blocks_.count();
  const Couplings c = BlockCouplings(blocks_, col_ptr_, rows_, values_);
  const std::vector<int> order = HeaviestFirst(c);
  Forest forest(nb);
  std::vector<bool> in(c.pairs.size(), false);
  for (int p : order) in[p] = forest.Join(c.pairs[p].first, c.pairs[p].second);
  other_pairs_ = c.pairs.size() - std::count(in.begin(), in.end(), true);
  extra_pairs_ = 0;
  if (options_.preconditioner == Preconditioner::kSubgraph)
    extra_pairs_ = AddWithinBudget(
        blocks_, c, order, options_.subgraph_fill * static_cast<double>(nb + c.pairs.size()), &in);
  std::vector<int> col_ptr{0}, rows;
  subgraph_source_.clear();
  for (int j = 0; j < n_; ++j) {
    for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k)
      if (c.pair_of[k] < 0 || in[c.pair_of[k]]) {
        rows.push_back(rows_[k]);
        subgraph_source_.push_back(k);
      }
    col_ptr.push_back(static_cast<int>(rows.size()));
  }
  subgraph_ = SparseCholesky::Create(Factorization::kSupernodalOrSimplicial);
  subgraph_->Analyze(n_, col_ptr, rows, block_sizes_);
}

// y = H x from the upper triangle.
void ConjugateGradients::Multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  y->setZero(n_);
  for (int j = 0; j < n_; ++j) {
    double sum = 0;
    const double xj = x[j];
    for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k) {
      const int i = rows_[k];
      const double v = values_[k];
      if (i == j) {
        sum += v * xj;
      } else {
        sum += v * x[i];
        (*y)[i] += v * xj;
      }
    }
    (*y)[j] += sum;
  }
}

void ConjugateGradients::Precondition(const Eigen::VectorXd& r, Eigen::VectorXd* z) const {
  if (use_subgraph_) {
    z->resize(n_);
    subgraph_->Solve(r.data(), z->data());
    return;
  }
  z->resize(n_);
  for (int b = 0; b < blocks_.count(); ++b)
    z->segment(blocks_.first[b], blocks_.size(b)) =
        diagonal_[b].solve(r.segment(blocks_.first[b], blocks_.size(b)));
}

void ConjugateGradients::Solve(const double* b_ptr, double* x_ptr) {
  const Eigen::Map<const Eigen::VectorXd> b(b_ptr, n_);
  Eigen::Map<Eigen::VectorXd> x(x_ptr, n_);
  x.setZero();
  Eigen::VectorXd r = b, z, p, hp;
  Precondition(r, &z);
  p = z;
  double rho = r.dot(z), model = 0;  // model: the quadratic x'Hx/2 - b'x, falling from 0
  const double stop_residual = 1e-14 * b.norm();
  const int max_iterations = options_.max_iterations > 0 ? options_.max_iterations : std::max(n_, 1);
  for (int it = 1; it <= max_iterations && r.norm() > stop_residual; ++it) {
    Multiply(p, &hp);
    const double curvature = p.dot(hp);
    if (!(curvature > 0)) {
      // H is not positive definite along p: no step, as a failed Cholesky.
      x.setConstant(std::numeric_limits<double>::quiet_NaN());
      return;
    }
    const double alpha = rho / curvature;
    x += alpha * p;
    r -= alpha * hp;
    const double fall = 0.5 * alpha * rho;
    model -= fall;
    if (it * fall <= -options_.tolerance * model) break;
    Precondition(r, &z);
    const double rho_next = r.dot(z);
    p = z + (rho_next / rho) * p;
    rho = rho_next;
  }
}

}  // namespace

std::unique_ptr<SparseCholesky> CreateConjugateGradients(const ConjugateGradientsOptions& options) {
  return std::make_unique<ConjugateGradients>(options);
}

}  // namespace cairn
