// The sparse Cholesky factorisations under the Gauss-Newton path: a grown
// matrix keeps its ordering, two halves at once solve exactly and refuse an
// indefinite matrix, and the serial linear-algebra scope.
#include <dlfcn.h>
#include <sys/resource.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <memory>
#include <string>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <utility>
#include <vector>

#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholmod_common.h"
#include "cairn/linear/domain_cholesky.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/linear/sparse_cholesky.h"

namespace cairn {
namespace {

// The upper triangle (compressed columns) of a random sparse SPD matrix of
// 3x3 blocks: a chain of blocks plus a few random couplings, with every
// coupling between blocks i < j listed in block column j.
struct BlockMatrix {
  int blocks = 0;
  std::vector<std::pair<int, int>> couplings;  // (i, j), i < j
  Eigen::MatrixXd Dense(unsigned seed) const {
    const int n = 3 * blocks;
    std::srand(seed);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
    for (const auto& [i, j] : couplings) {
      const Eigen::Matrix3d c = Eigen::Matrix3d::Random();
      a.block<3, 3>(3 * i, 3 * j) = c;
      a.block<3, 3>(3 * j, 3 * i) = c.transpose();
    }
    // Diagonally dominant, hence positive definite. (Summed by columns, which
    // are the rows of a symmetric matrix: a row's stride missed the cache.)
    for (int k = 0; k < n; ++k) a(k, k) = a.col(k).cwiseAbs().sum() + 1.0;
    return a;
  }
  // The pattern: full blocks, upper triangle only, rows sorted.
  void Pattern(std::vector<int>* col_ptr, std::vector<int>* rows) const {
    const int n = 3 * blocks;
    std::vector<std::vector<int>> above(blocks);  // block rows above the diagonal
    for (const auto& [i, j] : couplings) above[j].push_back(i);
    col_ptr->assign(1, 0);
    rows->clear();
    for (int b = 0; b < blocks; ++b) {
      std::sort(above[b].begin(), above[b].end());
      for (int c = 0; c < 3; ++c) {
        for (int i : above[b])
          for (int r = 0; r < 3; ++r) rows->push_back(3 * i + r);
        for (int r = 0; r <= c; ++r) rows->push_back(3 * b + r);
        col_ptr->push_back(static_cast<int>(rows->size()));
      }
    }
    (void)n;
  }
};

// a written into the factorisation (through `places` when given, else into
// values()), factorised, and b solved for.
Eigen::VectorXd SolveWith(SparseCholesky& chol, const Eigen::MatrixXd& a,
                          const std::vector<int>& col_ptr, const std::vector<int>& rows,
                          const Eigen::VectorXd& b, const ValuePlaces* places = nullptr) {
  double* v = places ? nullptr : chol.values();
  for (int j = 0; j + 1 < static_cast<int>(col_ptr.size()); ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) (places ? (*places)[k] : v[k]) = a(rows[k], j);
  EXPECT_TRUE(chol.Factorize());
  Eigen::VectorXd x(b.size());
  chol.Solve(b.data(), x.data());
  return x;
}

TEST(SparseCholesky, ExtendKeepsTheOrderAndSolvesTheGrownMatrix) {
  for (Factorization kind : {Factorization::kSupernodal, Factorization::kSimplicial,
                             Factorization::kSupernodalOrSimplicial}) {
    BlockMatrix m;
    m.blocks = 40;
    for (int i = 0; i + 1 < m.blocks; ++i) m.couplings.push_back({i, i + 1});
    for (int k = 0; k < 12; ++k) {
      const int i = (7 * k) % 30, j = i + 5 + k % 4;
      m.couplings.push_back({i, j});
    }
    std::vector<int> col_ptr, rows;
    m.Pattern(&col_ptr, &rows);
    auto chol = SparseCholesky::Create(kind);
    chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
    Eigen::MatrixXd a = m.Dense(1);
    Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1, 2);
    EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
    const std::vector<int> order = chol->BlockOrdering();

    // Two new blocks, coupled to old ones and to each other: columns at the end.
    BlockMatrix grown = m;
    grown.blocks += 2;
    grown.couplings.push_back({m.blocks - 1, m.blocks});
    grown.couplings.push_back({3, m.blocks});
    grown.couplings.push_back({m.blocks, m.blocks + 1});
    grown.couplings.push_back({17, m.blocks + 1});
    std::vector<int> grown_ptr, grown_rows;
    grown.Pattern(&grown_ptr, &grown_rows);
    ASSERT_TRUE(chol->Extend(3 * grown.blocks, grown_ptr, grown_rows,
                             std::vector<int>(grown.blocks, 3)));
    std::vector<int> extended = chol->BlockOrdering();
    if (!order.empty()) {
      ASSERT_EQ(extended.size(), order.size() + 2);
      EXPECT_TRUE(std::equal(order.begin(), order.end(), extended.begin()));
      EXPECT_EQ(extended[order.size()], m.blocks);
      EXPECT_EQ(extended[order.size() + 1], m.blocks + 1);
    }
    a = grown.Dense(2);
    b = Eigen::VectorXd::LinSpaced(a.rows(), 3, -1);
    EXPECT_LT((SolveWith(*chol, a, grown_ptr, grown_rows, b) - a.ldlt().solve(b)).norm(), 1e-10)
        << "factorisation " << static_cast<int>(kind);

    // A coupling between two old blocks changes an old column: refused,
    // and the factorisation is left as it was.
    BlockMatrix changed = grown;
    changed.couplings.push_back({2, 20});
    std::vector<int> changed_ptr, changed_rows;
    changed.Pattern(&changed_ptr, &changed_rows);
    EXPECT_FALSE(chol->Extend(3 * changed.blocks, changed_ptr, changed_rows,
                              std::vector<int>(changed.blocks, 3)));
    EXPECT_LT((SolveWith(*chol, a, grown_ptr, grown_rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
  }
}

// A grid of blocks (a city's streets) with a few long couplings: large
// enough to be cut into two halves, which CHOLMOD's single factorisation
// never sees.
BlockMatrix Grid(int side) {
  BlockMatrix m;
  m.blocks = side * side;
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      const int b = r * side + c;
      if (c + 1 < side) m.couplings.push_back({b, b + 1});
      if (r + 1 < side) m.couplings.push_back({b, b + side});
    }
  const int half = m.blocks / 2;
  for (int k = 0; k < 10; ++k) {
    const int i = (7 * k) % half, j = m.blocks - 1 - (11 * k) % half;
    if (j - i != 1 && j - i != side) m.couplings.push_back({i, j});
  }
  return m;
}

// A grid with its diagonals and couplings two apart: fill enough for the
// supernodal method in both halves.
BlockMatrix DenseGrid(int side) {
  BlockMatrix m = Grid(side);
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      const int b = r * side + c;
      if (c + 1 < side && r + 1 < side) m.couplings.push_back({b, b + side + 1});
      if (c + 2 < side) m.couplings.push_back({b, b + 2});
      if (r + 2 < side) m.couplings.push_back({b, b + 2 * side});
    }
  return m;
}

// A 24-block grid, sparse or dense by the parameter, with its pattern.
class TwoHalves : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override { m.Pattern(&col_ptr, &rows); }
  const bool dense = GetParam();
  const BlockMatrix m = dense ? DenseGrid(24) : Grid(24);
  std::vector<int> col_ptr, rows;
  const std::vector<int> sizes = std::vector<int>(m.blocks, 3);
};

TEST_P(TwoHalves, SolveExactly) {
  auto chol = CreateDomainCholesky(/*min_work=*/0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  ASSERT_NE(chol->Method().find("two halves"), std::string::npos) << chol->Method();
  // CHOLMOD's choice for the halves: the sparse grid's simplicial, the
  // denser one's supernodal; both ways of reading the separator's block.
  EXPECT_NE(chol->Method().find(dense ? "(supernodal, supernodal)" : "(simplicial, simplicial)"),
            std::string::npos) << chol->Method();
  const Eigen::MatrixXd a = m.Dense(5);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -2, 1);
  const Eigen::VectorXd expected = a.ldlt().solve(b);
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - expected).norm(), 1e-10 * expected.norm());
  // Its factor has the fill of one factorisation in the same order (the
  // separator's block counted dense).
  auto whole = SparseCholesky::Create(dense ? Factorization::kSupernodal
                                            : Factorization::kSimplicial);
  whole->SetBlockOrdering(chol->BlockOrdering());
  whole->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  SolveWith(*whole, a, col_ptr, rows, b);
  EXPECT_NEAR(static_cast<double>(chol->FactorNonZeros()) / whole->FactorNonZeros(), 1.0, 0.1);

  // Refactorised with other values, then with a given order (a graph that
  // grew): cut in that order's elimination tree.
  const Eigen::MatrixXd a2 = m.Dense(6);
  EXPECT_LT((SolveWith(*chol, a2, col_ptr, rows, b) - a2.ldlt().solve(b)).norm(), 1e-9);
  auto given = CreateDomainCholesky(0);
  given->SetBlockOrdering(chol->BlockOrdering());
  given->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  EXPECT_NE(given->Method().find("two halves"), std::string::npos) << given->Method();
  EXPECT_LT((SolveWith(*given, a, col_ptr, rows, b) - expected).norm(), 1e-10 * expected.norm());
}

TEST_P(TwoHalves, RefuseAMatrixThatIsNotPositiveDefinite) {
  auto chol = CreateDomainCholesky(0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  ASSERT_NE(chol->Method().find("two halves"), std::string::npos);
  // Indefinite in each block in turn: in either half or in the separator.
  const Eigen::MatrixXd positive = m.Dense(7);
  double* v = chol->values();
  for (int j = 0; j + 1 < static_cast<int>(col_ptr.size()); ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) v[k] = positive(rows[k], j);
  for (int block = 0; block < m.blocks; ++block) {
    const int diagonal = col_ptr[3 * block + 1] - 1;  // rows sorted: the last of its column
    const double kept = v[diagonal];
    v[diagonal] = -1;
    EXPECT_FALSE(chol->Factorize()) << "block " << block;
    v[diagonal] = kept;
  }
  // And positive definite again afterwards.
  const Eigen::MatrixXd a = m.Dense(8);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(a.rows());
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-9);
}

// Writing H where the factorisation reads it (TakeValuesInPlace) gives
// the very same solution as writing the caller's layout, for each way of
// factorising: the two halves (each method, the separator's block written
// once for both), one supernodal or simplicial factorisation, and again
// after new values and after the pattern grew (Extend: places taken anew).
ValuePlaces TakePlaces(SparseCholesky& chol, size_t entries) {
  ValuePlaces places;
  EXPECT_TRUE(chol.TakeValuesInPlace(&places));
  EXPECT_EQ(places.index.size(), entries);
  ValuePlaces again;
  EXPECT_FALSE(chol.TakeValuesInPlace(&again));  // once per analysis
  return places;
}

TEST_P(TwoHalves, ValuesWrittenInPlaceSolveAsTheirCopy) {
  const Eigen::MatrixXd a = m.Dense(9), a2 = m.Dense(10);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1, 2);
  std::vector<std::pair<std::string, std::unique_ptr<SparseCholesky>>> copy, in_place;
  for (auto* set : {&copy, &in_place}) {
    set->emplace_back("two halves", CreateDomainCholesky(0));
    set->emplace_back("supernodal", SparseCholesky::Create(Factorization::kSupernodal));
    set->emplace_back("simplicial", SparseCholesky::Create(Factorization::kSimplicial));
    set->emplace_back("CHOLMOD's choice",
                      SparseCholesky::Create(Factorization::kSupernodalOrSimplicial));
  }
  for (size_t c = 0; c < copy.size(); ++c) {
    SCOPED_TRACE(copy[c].first);
    SparseCholesky& by_copy = *copy[c].second;
    SparseCholesky& by_place = *in_place[c].second;
    by_copy.Analyze(3 * m.blocks, col_ptr, rows, sizes);
    by_place.Analyze(3 * m.blocks, col_ptr, rows, sizes);
    if (c == 0) ASSERT_NE(by_place.Method().find("two halves"), std::string::npos);
    const Eigen::VectorXd x = SolveWith(by_copy, a, col_ptr, rows, b);
    EXPECT_LT((x - a.ldlt().solve(b)).norm(), 1e-10 * x.norm());
    const ValuePlaces places = TakePlaces(by_place, rows.size());
    EXPECT_EQ(SolveWith(by_place, a, col_ptr, rows, b, &places), x);
    EXPECT_EQ(SolveWith(by_place, a2, col_ptr, rows, b, &places),
              SolveWith(by_copy, a2, col_ptr, rows, b));
  }
  // A single factorisation extended: the old places are gone, new ones taken.
  BlockMatrix grown = m;
  grown.blocks += 2;
  grown.couplings.push_back({m.blocks - 1, m.blocks});
  grown.couplings.push_back({m.blocks, m.blocks + 1});
  std::vector<int> grown_ptr, grown_rows;
  grown.Pattern(&grown_ptr, &grown_rows);
  const Eigen::MatrixXd g = grown.Dense(11);
  const Eigen::VectorXd gb = Eigen::VectorXd::Ones(g.rows());
  SparseCholesky& by_place = *in_place[1].second;
  ASSERT_TRUE(by_place.Extend(3 * grown.blocks, grown_ptr, grown_rows,
                              std::vector<int>(grown.blocks, 3)));
  const ValuePlaces places = TakePlaces(by_place, grown_rows.size());
  EXPECT_LT(
      (SolveWith(by_place, g, grown_ptr, grown_rows, gb, &places) - g.ldlt().solve(gb)).norm(),
      1e-9);
}

// Out of core (the halves' factors over the memory they are allowed), one
// factor in memory at a time and the other parked in a temporary file: the
// same arithmetic, so the same solution to the last bit as in memory, for
// a second solve with the same factor (a chord step), new values, and
// values written in place. Simplicial halves are never parked.
TEST_P(TwoHalves, OutOfCoreSolvesAsInMemory) {
  auto in_memory = CreateDomainCholesky(0, 2, -1);
  auto out_of_core = CreateDomainCholesky(0, 2, -1, /*resident_factor_bytes=*/0);
  in_memory->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  out_of_core->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  EXPECT_EQ(in_memory->Method().find("on disk"), std::string::npos) << in_memory->Method();
  EXPECT_EQ(out_of_core->Method().find("one at a time") != std::string::npos, dense)
      << out_of_core->Method();
  const Eigen::MatrixXd a = m.Dense(12), a2 = m.Dense(13);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1, 2);
  const Eigen::VectorXd x = SolveWith(*in_memory, a, col_ptr, rows, b);
  EXPECT_LT((x - a.llt().solve(b)).norm(), 1e-10 * x.norm());
  EXPECT_EQ(SolveWith(*out_of_core, a, col_ptr, rows, b), x);
  const Eigen::VectorXd b2 = Eigen::VectorXd::LinSpaced(a.rows(), 3, -1);
  Eigen::VectorXd again(b.size()), expected(b.size());
  in_memory->Solve(b2.data(), expected.data());
  out_of_core->Solve(b2.data(), again.data());
  EXPECT_EQ(again, expected);
  out_of_core->Solve(b.data(), again.data());  // the other half in memory now
  EXPECT_EQ(again, x);
  EXPECT_EQ(SolveWith(*out_of_core, a2, col_ptr, rows, b),
            SolveWith(*in_memory, a2, col_ptr, rows, b));
  ValuePlaces places;
  ASSERT_TRUE(out_of_core->TakeValuesInPlace(&places));
  EXPECT_EQ(SolveWith(*out_of_core, a, col_ptr, rows, b, &places), x);
}

// With no room on disk for the parked factor, both stay in memory.
TEST(SparseCholesky, TwoHalvesStayInMemoryWithoutASpillDirectory) {
  const BlockMatrix m = DenseGrid(24);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  const char* saved = std::getenv("TMPDIR");
  const std::string kept = saved ? saved : "";
  setenv("TMPDIR", "/nonexistent-cairn-spill-dir", 1);
  auto chol = CreateDomainCholesky(0, 2, -1, 0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
  if (saved) setenv("TMPDIR", kept.c_str(), 1); else unsetenv("TMPDIR");
  EXPECT_NE(chol->Method().find("two halves at once"), std::string::npos) << chol->Method();
  const Eigen::MatrixXd a = m.Dense(14);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(a.rows());
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.llt().solve(b)).norm(), 1e-9);
}

// A disk that fills up (here: a limit on the size of files this process
// writes) while a factor is parked: both halves stay in memory from then
// on, and every solve is still exact.
TEST(SparseCholesky, TwoHalvesStayInMemoryWhenTheDiskIsFull) {
  const BlockMatrix m = DenseGrid(24);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  auto chol = CreateDomainCholesky(0, 2, -1, 0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
  ASSERT_NE(chol->Method().find("one at a time"), std::string::npos) << chol->Method();
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  rlimit small = saved;
  small.rlim_cur = 4096;  // smaller than either half's factor
  void (*handler)(int) = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  const Eigen::MatrixXd a = m.Dense(15), a2 = m.Dense(16);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1, 1);
  const Eigen::VectorXd x = SolveWith(*chol, a, col_ptr, rows, b);
  const Eigen::VectorXd x2 = SolveWith(*chol, a2, col_ptr, rows, b);
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, handler);
  EXPECT_LT((x - a.llt().solve(b)).norm(), 1e-9);
  EXPECT_LT((x2 - a2.llt().solve(b)).norm(), 1e-9);
  EXPECT_NE(chol->Method().find("two halves at once"), std::string::npos) << chol->Method();
}

INSTANTIATE_TEST_SUITE_P(SparseCholesky, TwoHalves, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "Supernodal" : "Simplicial"; });

TEST(SparseCholesky, TwoHalvesLeaveASmallGraphToOneFactorisation) {
  BlockMatrix m = Grid(6);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  auto chol = CreateDomainCholesky();
  chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
  EXPECT_EQ(chol->Method().find("two halves"), std::string::npos) << chol->Method();
  const Eigen::MatrixXd a = m.Dense(9);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(a.rows());
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
}


// A planar grid of side `side` (one scalar unknown per node, a 5-point
// Laplacian plus the identity): upper triangle, rows sorted.
void GridPattern(int side, std::vector<int>* col_ptr, std::vector<int>* rows,
                 std::vector<double>* values) {
  col_ptr->assign(1, 0);
  for (int c = 0; c < side * side; ++c) {
    const int x = c % side, y = c / side;
    if (y > 0) rows->push_back(c - side), values->push_back(-1);
    if (x > 0) rows->push_back(c - 1), values->push_back(-1);
    rows->push_back(c), values->push_back(5);
    col_ptr->push_back(static_cast<int>(rows->size()));
  }
}

std::vector<int> AmdOrder(const BlockPattern& pattern, cholmod_common* common) {
  cholmod_sparse* graph = BlockGraph(pattern, common);
  std::vector<int> order(pattern.blocks());
  EXPECT_TRUE(cholmod_amd(graph, nullptr, 0, order.data(), common));
  cholmod_free_sparse(&graph, common);
  return order;
}

long FactorNonZerosIn(const std::vector<int>& order, int n, const std::vector<int>& col_ptr,
                      const std::vector<int>& rows, const std::vector<double>& values) {
  auto chol = SparseCholesky::Create(Factorization::kSupernodal);
  chol->SetBlockOrdering(order);
  chol->Analyze(n, col_ptr, rows, std::vector<int>(n, 1));
  std::copy(values.begin(), values.end(), chol->values());
  EXPECT_TRUE(chol->Factorize());
  // The solve is exact whatever the order: A x = b checked on the sparse matrix.
  std::vector<double> b(n), x(n), ax(n, 0.0);
  for (int i = 0; i < n; ++i) b[i] = std::sin(0.1 * i);
  chol->Solve(b.data(), x.data());
  for (int j = 0; j < n; ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) {
      ax[rows[k]] += values[k] * x[j];
      if (rows[k] != j) ax[j] += values[k] * x[rows[k]];
    }
  for (int i = 0; i < n; ++i) EXPECT_NEAR(ax[i], b[i], 1e-10) << i;
  return chol->FactorNonZeros();
}

// On a large planar graph nested dissection fills far less than AMD, and is
// taken; below the size asked for the order stays AMD's (results there
// unchanged). A lower bound than the default keeps the test small.
TEST(BlockOrdering, LargePlanarGraphsTakeNestedDissection) {
  CholmodCommon common;
  const int min_blocks = 40000;
  ASSERT_GT(kNestedDissectionMinBlocks, 240 * 240);
  for (int side : {60, 240}) {
    std::vector<int> col_ptr, rows;
    std::vector<double> values;
    GridPattern(side, &col_ptr, &rows, &values);
    const int n = side * side;
    const BlockPattern pattern = MakeBlockPattern(n, col_ptr, rows, std::vector<int>(n, 1));
    const std::vector<int> chosen = FillReducingBlockOrder(pattern, common.get(), min_blocks);
    const std::vector<int> amd = AmdOrder(pattern, common.get());
    EXPECT_EQ(FillReducingBlockOrder(pattern, common.get()), amd) << "below the default bound";
    ASSERT_EQ(static_cast<int>(chosen.size()), n);
    std::vector<int> sorted = chosen;
    std::sort(sorted.begin(), sorted.end());
    for (int i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);
    if (n < min_blocks) {
      EXPECT_EQ(chosen, amd) << side;
      continue;
    }
    const long nd_nnz = FactorNonZerosIn(chosen, n, col_ptr, rows, values);
    const long amd_nnz = FactorNonZerosIn(amd, n, col_ptr, rows, values);
    EXPECT_LT(nd_nnz, 0.9 * amd_nnz) << "nested dissection " << nd_nnz << ", AMD " << amd_nnz;
  }
}

// The grid's matrix as CHOLMOD holds it (upper triangle), and A x for it.
cholmod_sparse* GridMatrix(int side, cholmod_common* common, std::vector<int>* col_ptr,
                           std::vector<int>* rows, std::vector<double>* values) {
  GridPattern(side, col_ptr, rows, values);
  const int n = side * side;
  cholmod_sparse* a =
      cholmod_allocate_sparse(n, n, rows->size(), 1, 1, /*stype=*/1, CHOLMOD_REAL, common);
  std::copy(col_ptr->begin(), col_ptr->end(), static_cast<int*>(a->p));
  std::copy(rows->begin(), rows->end(), static_cast<int*>(a->i));
  std::copy(values->begin(), values->end(), static_cast<double*>(a->x));
  return a;
}

// A factor above the bound is analysed again with CHOLMOD's finer
// supernodes: fewer stored entries, the same nonzeros and the same solution;
// at or below it the coarse supernodes stay.
TEST(CholmodCommon, LargeFactorsTakeFinerSupernodes) {
  CholmodCommon common;
  std::vector<int> col_ptr, rows;
  std::vector<double> values;
  cholmod_sparse* a = GridMatrix(120, common.get(), &col_ptr, &rows, &values);
  const int n = static_cast<int>(a->nrow);
  common->supernodal = CHOLMOD_SUPERNODAL;
  cholmod_dense* b = cholmod_ones(n, 1, CHOLMOD_REAL, common.get());
  size_t xsize[2];
  double lnz[2];
  Eigen::VectorXd x[2];
  for (int fine = 0; fine < 2; ++fine) {
    cholmod_factor* f = common.Analyze(a, fine ? 0.0 : 1e18);
    ASSERT_NE(f, nullptr);
    ASSERT_TRUE(f->is_super);
    lnz[fine] = common->lnz;
    ASSERT_TRUE(cholmod_factorize(a, f, common.get()));
    xsize[fine] = f->xsize;
    cholmod_dense* sol = cholmod_solve(CHOLMOD_A, f, b, common.get());
    x[fine] = Eigen::Map<Eigen::VectorXd>(static_cast<double*>(sol->x), n);
    cholmod_free_dense(&sol, common.get());
    cholmod_free_factor(&f, common.get());
  }
  EXPECT_LT(xsize[1], 0.9 * xsize[0]) << "fine " << xsize[1] << ", coarse " << xsize[0];
  EXPECT_EQ(lnz[0], lnz[1]);
  EXPECT_LT((x[1] - x[0]).norm(), 1e-12 * x[0].norm());
  // The default bound (8 million nonzeros) leaves this small factor coarse;
  // and the settings are coarse again after a fine analysis.
  ASSERT_LT(lnz[0], CholmodCommon::kFineSupernodesMinNonZeros);
  for (int k = 0; k < 2; ++k) {
    cholmod_factor* f = common.Analyze(a);
    EXPECT_EQ(f->xsize, xsize[0]);
    cholmod_free_factor(&f, common.get());
  }
  cholmod_free_dense(&b, common.get());
  cholmod_free_sparse(&a, common.get());
}

// Sides of a grid split by a column of nodes: each side's nested
// dissection orders exactly that side's blocks, and with the separator last
// it fills far less than the sides' natural (banded) orders.
TEST(BlockOrdering, SideNestedDissectionOrdersOneSideAlone) {
  CholmodCommon common;
  const int side = 60, n = side * side;
  std::vector<int> col_ptr, rows;
  std::vector<double> values;
  GridPattern(side, &col_ptr, &rows, &values);
  const BlockPattern pattern = MakeBlockPattern(n, col_ptr, rows, std::vector<int>(n, 1));
  std::vector<int> sides(n);
  for (int b = 0; b < n; ++b) sides[b] = b % side < 29 ? 0 : b % side == 29 ? 2 : 1;
  std::vector<int> dissected, banded;
  for (int s = 0; s < 2; ++s) {
    const std::vector<int> nd = SideNestedDissection(pattern, sides, s, common.get());
    std::vector<int> expected;
    for (int b = 0; b < n; ++b)
      if (sides[b] == s) expected.push_back(b);
    std::vector<int> sorted = nd;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, expected) << "side " << s;
    EXPECT_NE(nd, expected) << "side " << s << " left in its natural order";
    dissected.insert(dissected.end(), nd.begin(), nd.end());
    banded.insert(banded.end(), expected.begin(), expected.end());
  }
  for (int b = 0; b < n; ++b)
    if (sides[b] == 2) dissected.push_back(b), banded.push_back(b);
  const double nd_flops = BlockFactorFlops(pattern, &dissected, common.get());
  const double banded_flops = BlockFactorFlops(pattern, &banded, common.get());
  EXPECT_LT(nd_flops, 0.5 * banded_flops) << nd_flops << " against " << banded_flops;
  std::vector<int> none(n, 2);
  EXPECT_TRUE(SideNestedDissection(pattern, none, 0, common.get()).empty());
}

// Two halves of a graph at or above the bound are ordered by nested
// dissection within each half: the same solution, less fill than CAMD's
// order of the halves (the default bound, far above this grid, keeps CAMD).
TEST(SparseCholesky, LargeHalvesTakeNestedDissection) {
  const int side = 400, n = side * side;
  std::vector<int> col_ptr, rows;
  std::vector<double> values;
  GridPattern(side, &col_ptr, &rows, &values);
  const std::vector<int> sizes(n, 1);
  long nonzeros[2];
  std::vector<double> x[2];
  for (int nd = 0; nd < 2; ++nd) {
    auto chol = CreateDomainCholesky(/*min_work=*/0, 2, nd ? n : -1);
    chol->Analyze(n, col_ptr, rows, sizes);
    ASSERT_NE(chol->Method().find("two halves"), std::string::npos) << chol->Method();
    std::copy(values.begin(), values.end(), chol->values());
    ASSERT_TRUE(chol->Factorize());
    std::vector<double> b(n);
    for (int i = 0; i < n; ++i) b[i] = std::cos(0.01 * i);
    x[nd].resize(n);
    chol->Solve(b.data(), x[nd].data());
    nonzeros[nd] = chol->FactorNonZeros();
  }
  EXPECT_LT(nonzeros[1], 0.95 * nonzeros[0]) << nonzeros[1] << " against " << nonzeros[0];
  for (int i = 0; i < n; ++i) EXPECT_NEAR(x[1][i], x[0][i], 1e-10 * std::abs(x[0][i]) + 1e-13);
  // The same order, hence the same bits, every time (METIS's random state is
  // the process's: the halves are dissected one after the other).
  for (int again = 0; again < 2; ++again) {
    auto chol = CreateDomainCholesky(0, 2, n);
    chol->Analyze(n, col_ptr, rows, sizes);
    std::copy(values.begin(), values.end(), chol->values());
    ASSERT_TRUE(chol->Factorize());
    std::vector<double> b(n), y(n);
    for (int i = 0; i < n; ++i) b[i] = std::cos(0.01 * i);
    chol->Solve(b.data(), y.data());
    EXPECT_EQ(y, x[1]) << "run " << again;
  }
}

TEST(SerialLinearAlgebraScope, TurnsLibraryThreadsOffAndRestoresThem) {
  auto get_levels = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  auto get_blas = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  auto set_blas = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (!get_levels && !get_blas) GTEST_SKIP() << "neither OpenMP nor OpenBLAS is loaded";
  if (set_blas) set_blas(2);
  const int levels = get_levels ? get_levels() : 0;
  {
    SerialLinearAlgebraScope outer;
    if (get_levels) EXPECT_EQ(get_levels(), 0);
    if (get_blas) EXPECT_EQ(get_blas(), 1);
    {
      SerialLinearAlgebraScope inner;  // nests
      if (get_blas) EXPECT_EQ(get_blas(), 1);
    }
    if (get_levels) EXPECT_EQ(get_levels(), 0);
    if (get_blas) EXPECT_EQ(get_blas(), 1);
  }
  if (get_levels) EXPECT_EQ(get_levels(), levels);
  if (get_blas) EXPECT_EQ(get_blas(), 2);
}

}  // namespace
}  // namespace cairn
