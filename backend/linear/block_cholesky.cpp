#include "cairn/linear/block_cholesky.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholmod_common.h"

namespace cairn {

void BlockMatrix::Add(int r, int c, const Eigen::MatrixXd& h) {
  if (h.rows() != d || h.cols() != d || r < 0 || c < 0 || r >= blocks || c >= blocks)
    throw std::invalid_argument("BlockMatrix::Add: block out of range");
  const Eigen::MatrixXd lower = r >= c ? h : Eigen::MatrixXd(h.transpose());
  row.push_back(std::max(r, c));
  col.push_back(std::min(r, c));
  values.insert(values.end(), lower.data(), lower.data() + lower.size());
}

namespace {

// The factor's block pattern, in elimination order: column j lists its
// rows ascending, j itself first; the rows of a column below the diagonal
// are ancestors of it in the elimination tree, its parent the first.
struct Symbolic {
  std::vector<int> pos;     // per block: its column in the factor
  std::vector<int> cp, ri;  // compressed columns
};

// AMD on the block graph, postordered, then each column's rows: the
// matrix's own, and its children's below it (the pattern is chordal).
Symbolic Analyse(const BlockMatrix& h) {
  const int nb = h.blocks;
  BlockPattern pattern;
  pattern.first.resize(nb + 1);
  for (int b = 0; b <= nb; ++b) pattern.first[b] = b;
  std::vector<std::vector<int>> upper(nb);
  for (int b = 0; b < nb; ++b) upper[b].push_back(b);
  for (size_t k = 0; k < h.row.size(); ++k)
    if (h.row[k] != h.col[k]) upper[h.row[k]].push_back(h.col[k]);
  pattern.bp.push_back(0);
  for (std::vector<int>& u : upper) {
    std::sort(u.begin(), u.end());
    u.erase(std::unique(u.begin(), u.end()), u.end());
    pattern.bi.insert(pattern.bi.end(), u.begin(), u.end());
    pattern.bp.push_back(static_cast<int>(pattern.bi.size()));
  }
  CholmodCommon common;
  std::vector<int> order = FillReducingBlockOrder(pattern, common.get());
  if (static_cast<int>(order.size()) != nb) throw std::runtime_error("block ordering failed");
  std::vector<int> parent;
  order = Postordered(order, pattern, &parent);

  Symbolic s;
  s.pos.resize(nb);
  for (int k = 0; k < nb; ++k) s.pos[order[k]] = k;
  std::vector<std::vector<int>> below(nb), children(nb);
  for (int b = 0; b < nb; ++b)
    for (int c : upper[b])
      if (c != b) {
        const int i = s.pos[b], j = s.pos[c];
        below[std::min(i, j)].push_back(std::max(i, j));
      }
  for (int k = 0; k < nb; ++k)
    if (parent[k] >= 0) children[parent[k]].push_back(k);
  std::vector<int> mark(nb, -1), rows;
  s.cp.push_back(0);
  for (int j = 0; j < nb; ++j) {
    rows.clear();
    mark[j] = j;
    auto add = [&](int i) {
      if (mark[i] != j) mark[i] = j, rows.push_back(i);
    };
    for (int i : below[j]) add(i);
    for (int c : children[j])
      for (int q = s.cp[c] + 1; q < s.cp[c + 1]; ++q)
        if (s.ri[q] != j) add(s.ri[q]);
    std::sort(rows.begin(), rows.end());
    s.ri.push_back(j);
    s.ri.insert(s.ri.end(), rows.begin(), rows.end());
    s.cp.push_back(static_cast<int>(s.ri.size()));
  }
  return s;
}

template <int D>
class Factor final : public BlockCholesky {
 public:
  using Block = Eigen::Matrix<double, D, D>;

  Factor(const BlockMatrix& h, Symbolic s) : s_(std::move(s)), l_(s_.ri.size(), Block::Zero()) {
    const Eigen::Index n = static_cast<Eigen::Index>(h.row.size());
    for (Eigen::Index k = 0; k < n; ++k) {
      const Eigen::Map<const Block> v(h.values.data() + D * D * k);
      const int i = s_.pos[h.row[k]], j = s_.pos[h.col[k]];
      if (i >= j) l_[Find(i, j)] += v;
      else l_[Find(j, i)] += v.transpose();
    }
    const int nb = static_cast<int>(s_.pos.size());
    for (int j = 0; j < nb; ++j) EliminateColumn(j);
  }

  Eigen::MatrixXd Inverse(int r, int c) override {
    if (z_.empty()) SelectInverse();
    const int i = s_.pos.at(r), j = s_.pos.at(c);
    if (i >= j) return z_[Find(i, j)];
    return z_[Find(j, i)].transpose();
  }

  Eigen::MatrixXd Gram(const std::vector<int>& rows, const Eigen::MatrixXd& b) override {
    if (b.rows() != D * static_cast<Eigen::Index>(rows.size()))
      throw std::invalid_argument("BlockCholesky::Gram: B's rows do not match the blocks");
    if (place_.empty()) place_.assign(s_.pos.size(), -1);
    reach_.clear();
    for (int r : rows)
      for (int j = s_.pos.at(r); j >= 0 && place_[j] < 0; j = Parent(j)) {
        place_[j] = 0;
        reach_.push_back(j);
      }
    std::sort(reach_.begin(), reach_.end());
    for (size_t t = 0; t < reach_.size(); ++t) place_[reach_[t]] = static_cast<int>(t);
    Eigen::MatrixXd y = Eigen::MatrixXd::Zero(D * static_cast<Eigen::Index>(reach_.size()), b.cols());
    for (size_t c = 0; c < rows.size(); ++c)
      y.middleRows(D * place_[s_.pos[rows[c]]], D) += b.middleRows(D * c, D);
    for (int j : reach_) {
      auto yj = y.middleRows(D * place_[j], D);
      l_[s_.cp[j]].template triangularView<Eigen::Lower>().solveInPlace(yj);
      for (int q = s_.cp[j] + 1; q < s_.cp[j + 1]; ++q)
        y.middleRows(D * place_[s_.ri[q]], D).noalias() -= l_[q] * yj;
    }
    for (int j : reach_) place_[j] = -1;
    return y.transpose() * y;
  }

 private:
  // The entry of block (i, j), i >= j, in factor order.
  int Find(int i, int j) const {
    const auto begin = s_.ri.begin() + s_.cp[j], end = s_.ri.begin() + s_.cp[j + 1];
    const auto it = std::lower_bound(begin, end, i);
    if (it == end || *it != i) throw std::logic_error("block Cholesky: a block off the pattern");
    return static_cast<int>(it - s_.ri.begin());
  }

  int Parent(int j) const { return s_.cp[j + 1] - s_.cp[j] > 1 ? s_.ri[s_.cp[j] + 1] : -1; }

  // Column j's own factorisation, then its outer product subtracted from
  // the columns it reaches (right-looking). Rows of column j at or below
  // row k are rows of column k: one merge of two sorted lists finds them.
  void EliminateColumn(int j) {
    const int p0 = s_.cp[j], p1 = s_.cp[j + 1];
    const Eigen::LLT<Block> llt(l_[p0]);
    if (llt.info() != Eigen::Success || !l_[p0].allFinite())
      throw std::runtime_error("the information matrix is not positive definite");
    l_[p0] = llt.matrixL();
    const Block inv_t = LowerInverse(l_[p0]).transpose();
    for (int a = p0 + 1; a < p1; ++a) l_[a] = (l_[a] * inv_t).eval();
    for (int b = p0 + 1; b < p1; ++b) {
      const int k = s_.ri[b];
      int q = s_.cp[k];
      for (int a = b; a < p1; ++a) {
        q = Advance(q, s_.cp[k + 1], s_.ri[a]);
        l_[q].noalias() -= l_[a] * l_[b].transpose();
      }
    }
  }

  // Takahashi's recurrence in blocks, from the last column back. With
  // F_kj = L_kj L_jj^{-1}:
  //   Z_ij = -sum_{k in col j} Z_ik F_kj          (i > j)
  //   Z_jj = (L_jj L_jj^T)^{-1} - sum_k Z_kj^T F_kj
  // Every Z_ik needed lies on the pattern (it is chordal).
  void SelectInverse() {
    z_.assign(l_.size(), Block::Zero());
    std::vector<Block, Eigen::aligned_allocator<Block>> f, sum;
    for (int j = static_cast<int>(s_.pos.size()) - 1; j >= 0; --j) {
      const int p0 = s_.cp[j], p1 = s_.cp[j + 1];
      const Block inv = LowerInverse(l_[p0]);
      f.resize(p1 - p0);
      sum.assign(p1 - p0, Block::Zero());
      for (int a = p0 + 1; a < p1; ++a) f[a - p0] = l_[a] * inv;
      for (int b = p0 + 1; b < p1; ++b) {
        const int k = s_.ri[b];
        int q = s_.cp[k];
        for (int a = b; a < p1; ++a) {
          q = Advance(q, s_.cp[k + 1], s_.ri[a]);
          sum[a - p0].noalias() += z_[q] * f[b - p0];
          if (a != b) sum[b - p0].noalias() += z_[q].transpose() * f[a - p0];
        }
      }
      Block zjj = inv.transpose() * inv;
      for (int a = p0 + 1; a < p1; ++a) {
        z_[a] = -sum[a - p0];
        zjj.noalias() -= z_[a].transpose() * f[a - p0];
      }
      z_[p0] = 0.5 * (zjj + zjj.transpose());
    }
  }

  int Advance(int q, int end, int row) const {
    while (q < end && s_.ri[q] < row) ++q;
    if (q == end || s_.ri[q] != row) throw std::logic_error("block Cholesky: pattern not chordal");
    return q;
  }

  static Block LowerInverse(const Block& l) {
    Block inv = Block::Identity();
    l.template triangularView<Eigen::Lower>().solveInPlace(inv);
    return inv;
  }

  Symbolic s_;
  std::vector<Block, Eigen::aligned_allocator<Block>> l_, z_;
  std::vector<int> place_, reach_;  // Gram's work: per column its place in reach_
};

template <int D>
std::unique_ptr<BlockCholesky> Make(const BlockMatrix& h) {
  return std::make_unique<Factor<D>>(h, Analyse(h));
}

}  // namespace

std::unique_ptr<BlockCholesky> BlockCholesky::Factorize(const BlockMatrix& h) {
  if (h.values.size() != static_cast<size_t>(h.d * h.d) * h.row.size())
    throw std::invalid_argument("BlockCholesky: values do not match the blocks");
  switch (h.d) {
    case 1: return Make<1>(h);
    case 2: return Make<2>(h);
    case 3: return Make<3>(h);
    case 4: return Make<4>(h);
    case 5: return Make<5>(h);
    case 6: return Make<6>(h);
    default:
      throw std::invalid_argument("BlockCholesky: block size " + std::to_string(h.d) +
                                  " (1 to 6 only)");
  }
}

}  // namespace cairn
