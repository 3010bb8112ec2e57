#include "cairn/linear/conjugate_gradients.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cairn {
namespace {

using Sparse = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

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
    tree_chosen_ = false;
    use_tree_ = options_.preconditioner == Preconditioner::kSpanningTree;
  }

  double* values() override { return values_.data(); }

  bool Factorize() override {
    if (!FactorDiagonalBlocks()) return false;
    if (!use_tree_) return true;
    if (!tree_chosen_) ChooseTree();
    for (size_t k = 0; k < tree_source_.size(); ++k) tree_.valuePtr()[k] = values_[tree_source_[k]];
    tree_llt_.factorize(tree_);
    // Not positive definite only when a residual joins three or more blocks.
    if (tree_llt_.info() != Eigen::Success) use_tree_ = false;
    return true;
  }

  void Solve(const double* b, double* x) override;

  long FactorNonZeros() const override {
    long nz = 0;
    for (int b = 0; b < blocks_.count(); ++b) nz += blocks_.size(b) * (blocks_.size(b) + 1) / 2;
    if (use_tree_ && tree_chosen_) nz = static_cast<long>(tree_.nonZeros());
    return nz;
  }
  bool IsSupernodal() const override { return false; }
  std::string Method() const override {
    return use_tree_ ? "conjugate gradients, spanning-tree preconditioner"
                     : "conjugate gradients, block-Jacobi preconditioner";
  }

 private:
  bool FactorDiagonalBlocks();
  void ChooseTree();
  void Multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
  void Precondition(const Eigen::VectorXd& r, Eigen::VectorXd* z) const;

  const ConjugateGradientsOptions options_;
  int n_ = 0;
  std::vector<int> col_ptr_, rows_;
  std::vector<double> values_;
  Blocks blocks_;
  std::vector<Eigen::LLT<Eigen::MatrixXd>> diagonal_;
  bool use_tree_ = true, tree_chosen_ = false;
  Sparse tree_;                   // H on the tree's pattern, upper triangle
  std::vector<int> tree_source_;  // for each of tree_'s values, its index in values_
  Eigen::SimplicialLLT<Sparse, Eigen::Upper> tree_llt_;
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

// Kruskal on the block graph, heaviest relative coupling first; then the
// tree's pattern (whole diagonal blocks and the tree's off-diagonal ones)
// and its symbolic factorisation, once: later factorisations refill it.
void ConjugateGradients::ChooseTree() {
  const int nb = blocks_.count();
  std::vector<double> diag_norm(nb, 0.0), pair_norm;
  std::vector<std::pair<int, int>> pairs;  // (row block, column block), row < column
  std::vector<int> pair_of(values_.size(), -1);
  std::vector<int> pair_in_column(nb, -1);  // for the current column block
  for (int bj = 0; bj < nb; ++bj) {
    const size_t column_pairs = pairs.size();
    for (int j = blocks_.first[bj]; j < blocks_.first[bj + 1]; ++j)
      for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k) {
        const int bi = blocks_.of[rows_[k]];
        const double v2 = values_[k] * values_[k];
        if (bi == bj) {
          diag_norm[bj] += v2;
          continue;
        }
        if (pair_in_column[bi] < 0) {
          pair_in_column[bi] = static_cast<int>(pairs.size());
          pairs.emplace_back(bi, bj);
          pair_norm.push_back(0.0);
        }
        pair_of[k] = pair_in_column[bi];
        pair_norm[pair_of[k]] += v2;
      }
    for (size_t p = column_pairs; p < pairs.size(); ++p) pair_in_column[pairs[p].first] = -1;
  }
  std::vector<double> weight(pairs.size());
  for (size_t p = 0; p < pairs.size(); ++p)
    weight[p] = std::sqrt(pair_norm[p] / std::max(std::sqrt(diag_norm[pairs[p].first] *
                                                            diag_norm[pairs[p].second]),
                                                  std::numeric_limits<double>::min()));
  std::vector<int> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return weight[a] > weight[b]; });
  Forest forest(nb);
  std::vector<bool> in_tree(pairs.size(), false);
  for (int p : order) in_tree[p] = forest.Join(pairs[p].first, pairs[p].second);
  std::vector<Eigen::Triplet<double, int>> entries;
  std::vector<int> kept;
  for (int j = 0; j < n_; ++j)
    for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k)
      if (pair_of[k] < 0 || in_tree[pair_of[k]]) {
        entries.emplace_back(rows_[k], j, static_cast<double>(kept.size()));
        kept.push_back(k);
      }
  tree_.resize(n_, n_);
  tree_.setFromTriplets(entries.begin(), entries.end());
  tree_.makeCompressed();
  // The triplets carried each entry's place in `kept` as its value.
  tree_source_.resize(kept.size());
  for (Eigen::Index k = 0; k < tree_.nonZeros(); ++k)
    tree_source_[k] = kept[static_cast<size_t>(tree_.valuePtr()[k])];
  tree_llt_.analyzePattern(tree_);
  tree_chosen_ = true;
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
  if (use_tree_) {
    *z = tree_llt_.solve(r);
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
