// BlockCholesky: the inverse's blocks on the factor's pattern and the
// forward solves' Gram matrices equal a dense inverse's, for the block
// sizes of 2D and 3D poses, on chains with random extra couplings.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <utility>
#include <vector>

#include "cairn/linear/block_cholesky.h"

namespace cairn {
namespace {

struct Case {
  BlockMatrix h;
  Eigen::MatrixXd dense;
  std::vector<std::pair<int, int>> coupled;  // pairs the matrix couples, r > c
};

// J^T J of random d x d "edges": a chain through every block, `extra`
// random pairs, a prior on block 0; the same block pair repeated adds.
Case RandomCase(int blocks, int d, int extra, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, blocks - 1);
  Case c{BlockMatrix(blocks, d), Eigen::MatrixXd::Zero(blocks * d, blocks * d), {}};
  auto add = [&](int a, int b) {
    const Eigen::MatrixXd ja = Eigen::MatrixXd::Random(d, d) + 2 * Eigen::MatrixXd::Identity(d, d);
    const Eigen::MatrixXd jb = Eigen::MatrixXd::Random(d, d);
    c.h.Add(a, a, ja.transpose() * ja);
    c.h.Add(b, b, jb.transpose() * jb);
    c.h.Add(b, a, jb.transpose() * ja);  // r < c in half of them: added transposed
    c.dense.block(a * d, a * d, d, d) += ja.transpose() * ja;
    c.dense.block(b * d, b * d, d, d) += jb.transpose() * jb;
    c.dense.block(b * d, a * d, d, d) += jb.transpose() * ja;
    c.dense.block(a * d, b * d, d, d) += ja.transpose() * jb;
    c.coupled.emplace_back(std::max(a, b), std::min(a, b));
  };
  srand(seed);
  for (int b = 1; b < blocks; ++b) add(b - 1, b);
  for (int k = 0; k < extra; ++k) {
    const int a = pick(rng), b = pick(rng);
    if (a != b) add(a, b);
  }
  const Eigen::MatrixXd prior = Eigen::MatrixXd::Identity(d, d);
  c.h.Add(0, 0, prior);
  c.dense.block(0, 0, d, d) += prior;
  return c;
}

class BlockSizes : public ::testing::TestWithParam<int> {};

TEST_P(BlockSizes, InverseBlocksOnThePatternMatchADenseInverse) {
  const int d = GetParam();
  for (unsigned seed : {1u, 2u, 3u}) {
    const Case c = RandomCase(60, d, 40, seed);
    const Eigen::MatrixXd sigma = c.dense.inverse();
    auto f = BlockCholesky::Factorize(c.h);
    const double scale = sigma.cwiseAbs().maxCoeff();
    for (int b = 0; b < c.h.blocks; ++b)
      EXPECT_LT((f->Inverse(b, b) - sigma.block(b * d, b * d, d, d)).cwiseAbs().maxCoeff(),
                1e-9 * scale);
    for (const auto& [r, col] : c.coupled) {
      EXPECT_LT((f->Inverse(r, col) - sigma.block(r * d, col * d, d, d)).cwiseAbs().maxCoeff(),
                1e-9 * scale);
      EXPECT_LT((f->Inverse(col, r) - sigma.block(col * d, r * d, d, d)).cwiseAbs().maxCoeff(),
                1e-9 * scale);
    }
  }
}

TEST_P(BlockSizes, GramOfFarApartBlocksMatchesADenseInverse) {
  const int d = GetParam();
  const Case c = RandomCase(80, d, 30, 7);
  const Eigen::MatrixXd sigma = c.dense.inverse();
  auto f = BlockCholesky::Factorize(c.h);
  // Blocks the matrix does not couple: off the selected inverse's reach.
  const std::vector<int> rows = {3, 41, 77};
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(d * 3, 2 * d);
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(c.dense.rows(), b.cols());
  for (size_t k = 0; k < rows.size(); ++k) full.middleRows(rows[k] * d, d) = b.middleRows(k * d, d);
  const Eigen::MatrixXd expected = full.transpose() * sigma * full;
  for (int repeat = 0; repeat < 2; ++repeat)  // the work arrays are reused
    EXPECT_LT((f->Gram(rows, b) - expected).cwiseAbs().maxCoeff(),
              1e-9 * expected.cwiseAbs().maxCoeff());
}

TEST_P(BlockSizes, AMatrixThatIsNotPositiveDefiniteIsRefused) {
  const int d = GetParam();
  Case c = RandomCase(20, d, 5, 4);
  c.h.Add(7, 7, -1e6 * Eigen::MatrixXd::Identity(d, d));
  EXPECT_THROW(BlockCholesky::Factorize(c.h), std::runtime_error);
}

INSTANTIATE_TEST_SUITE_P(TwoAndThreeDimensions, BlockSizes, ::testing::Values(1, 3, 6));

TEST(BlockCholesky, ABlockOffThePatternIsAnError) {
  // A chain: blocks 0 and 9 share no column of the factor whatever the order.
  BlockMatrix h(10, 3);
  for (int b = 0; b < 10; ++b) h.Add(b, b, 4 * Eigen::MatrixXd::Identity(3, 3));
  for (int b = 1; b < 10; ++b) h.Add(b, b - 1, -Eigen::MatrixXd::Identity(3, 3));
  auto f = BlockCholesky::Factorize(h);
  EXPECT_THROW(f->Inverse(0, 9), std::logic_error);
  EXPECT_THROW(BlockCholesky::Factorize(BlockMatrix(4, 7)), std::invalid_argument);
}

}  // namespace
}  // namespace cairn
