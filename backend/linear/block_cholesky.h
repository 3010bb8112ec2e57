// A sparse Cholesky factor kept in dense d x d blocks (one block row per
// pose), for what the leave-one-out tests of backend/robust read from it:
// blocks of the inverse on the factor's pattern (Takahashi's recurrence) and
// forward solves for a few block columns. A scalar factor of the same matrix
// spends its time on index arithmetic (sphere2500: 1.5 s per selected
// inverse); in blocks of 3 or 6 the work is small dense products. Internal
// to backend/.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace cairn {

// A symmetric matrix of `blocks` x `blocks` blocks of d x d, given by its
// lower blocks (row >= col); repeated blocks add up.
struct BlockMatrix {
  BlockMatrix(int blocks, int d) : blocks(blocks), d(d) {}
  // Block (r, c) += h; for r < c, block (c, r) += h^T.
  void Add(int r, int c, const Eigen::MatrixXd& h);

  int blocks, d;
  std::vector<int> row, col;
  std::vector<double> values;  // d * d per entry, column-major
};

class BlockCholesky {
 public:
  // Orders the blocks (AMD on the block graph, postordered) and factorises.
  // Block sizes 1 to 6 (std::invalid_argument otherwise); throws
  // std::runtime_error when the matrix is not positive definite.
  static std::unique_ptr<BlockCholesky> Factorize(const BlockMatrix& h);
  virtual ~BlockCholesky() = default;

  // Block (r, c) of the inverse, for a pair of blocks on the factor's
  // pattern (every pair the matrix couples, and each block with itself);
  // std::logic_error off it. The selected inverse is computed on first use.
  virtual Eigen::MatrixXd Inverse(int r, int c) = 0;
  // B^T H^{-1} B for a B whose block rows are `rows` (d rows each, zero
  // elsewhere): forward solves that walk only the elimination tree's paths
  // from those blocks.
  virtual Eigen::MatrixXd Gram(const std::vector<int>& rows, const Eigen::MatrixXd& b) = 0;
};

}  // namespace cairn
