#include "cairn/linear/sparse_cholesky.h"

#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholmod_common.h"
#include "cairn/linear/serial_scope.h"

#include <cholmod.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace cairn {

namespace {

class Cholmod final : public SparseCholesky {
 public:
  explicit Cholmod(int mode) {
    common_->supernodal = mode_ = mode;
  }
  ~Cholmod() override {
    if (factor_) cholmod_free_factor(&factor_, common_.get());
    if (a_) cholmod_free_sparse(&a_, common_.get());
    if (permuted_) cholmod_free_sparse(&permuted_, common_.get());
    if (x_) cholmod_free_dense(&x_, common_.get());
    if (b_) cholmod_free_dense(&b_, common_.get());
    if (y_) cholmod_free_dense(&y_, common_.get());
    if (e_) cholmod_free_dense(&e_, common_.get());
  }

  void Analyze(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
               const std::vector<int>& block_sizes) override {
    Release();
    SetPattern(n, col_ptr, rows);
    std::vector<int> perm = ScalarOrdering(n, col_ptr, rows, block_sizes);
    SerialLinearAlgebraScope serial;
    if (perm.empty()) {
      // Not blocked: CHOLMOD orders (AMD, postordered) and the permutation
      // is taken from its analysis.
      common_->supernodal = mode_ == CHOLMOD_AUTO ? CHOLMOD_AUTO : CHOLMOD_SIMPLICIAL;
      common_->method[0].ordering = CHOLMOD_AMD;
      common_->postorder = 1;
      cholmod_factor* ordered = cholmod_analyze(a_, common_.get());
      if (!ordered) throw std::runtime_error("CHOLMOD: symbolic analysis failed");
      perm.assign(static_cast<const int*>(ordered->Perm), static_cast<const int*>(ordered->Perm) + n);
      cholmod_free_factor(&ordered, common_.get());
    }
    perm_ = std::move(perm);
    // CHOLMOD's choice of method needs its analysis: made on the simplicial
    // layout, redone on the supernodal one only when that is its choice.
    supernodal_ = mode_ == CHOLMOD_SUPERNODAL;
    AnalyzePermuted(rows, col_ptr, mode_ == CHOLMOD_AUTO ? CHOLMOD_AUTO : -1);
    if (mode_ == CHOLMOD_AUTO && factor_->is_super) {
      const double nonzeros = common_->lnz;
      Release(/*keep_pattern=*/true);
      supernodal_ = true;
      AnalyzePermuted(rows, col_ptr, -1, nonzeros);
    }
  }

  bool Extend(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
              const std::vector<int>& block_sizes) override {
    // Only a matrix that grew by columns (and rows) at the end, the old
    // pattern untouched, keeps its elimination order.
    if (!a_ || !factor_ || n < n_) return false;
    const int* old_p = static_cast<const int*>(a_->p);
    const int* old_i = static_cast<const int*>(a_->i);
    const size_t old_nnz = static_cast<size_t>(old_p[n_]);
    if (rows.size() < old_nnz || !std::equal(old_p, old_p + n_ + 1, col_ptr.begin()) ||
        !std::equal(old_i, old_i + old_nnz, rows.begin()))
      return false;
    const int old_n = n_;
    Release();
    SetPattern(n, col_ptr, rows);
    // The new unknowns are eliminated last, in their own order: their
    // edges then reach only the end of the elimination, and the old part
    // of the factor keeps its fill. (IncrementalOptimizer orders afresh
    // once the graph has grown enough for that to matter.)
    for (int k = old_n; k < n; ++k) perm_.push_back(k);
    if (!used_.empty()) {
      const int old_blocks = static_cast<int>(used_.size());
      for (int b = old_blocks; b < static_cast<int>(block_sizes.size()); ++b) used_.push_back(b);
    }
    SerialLinearAlgebraScope serial;
    AnalyzePermuted(rows, col_ptr);
    return true;
  }

  double* values() override { return static_cast<double*>(a_->x); }

  bool TakeValuesInPlace(ValuePlaces* places) override {
    if (in_place_) return false;  // taken already: scatter_ is gone
    places->arrays[0] = static_cast<double*>(permuted_->x);
    places->arrays[1] = nullptr;
    places->index.assign(scatter_.begin(), scatter_.end());
    std::vector<int>().swap(scatter_);
    // a_ keeps its pattern, which Extend compares.
    cholmod_sparse_xtype(CHOLMOD_PATTERN, a_, common_.get());
    in_place_ = true;
    return true;
  }

  bool Factorize() override {
    if (!in_place_) {
      const double* from = static_cast<const double*>(a_->x);
      double* to = static_cast<double*>(permuted_->x);
      for (size_t k = 0; k < scatter_.size(); ++k) to[scatter_[k]] = from[k];
    }
    SerialLinearAlgebraScope serial;
    const int ok = cholmod_factorize(permuted_, factor_, common_.get());
    return ok && common_->status == CHOLMOD_OK;
  }

  void Solve(const double* b, double* x) override {
    double* pb = static_cast<double*>(b_->x);
    for (int k = 0; k < n_; ++k) pb[k] = b[perm_[k]];
    SerialLinearAlgebraScope serial;
    // cholmod_solve2 keeps its result and workspace between calls.
    cholmod_solve2(CHOLMOD_A, factor_, b_, nullptr, &x_, nullptr, &y_, &e_, common_.get());
    const double* px = static_cast<const double*>(x_->x);
    for (int k = 0; k < n_; ++k) x[perm_[k]] = px[k];
  }

  long FactorNonZeros() const override {
    if (!factor_) return 0;
    if (factor_->is_super) return SupernodalNonZeros(factor_);
    long nz = 0;
    const int* cnt = static_cast<const int*>(factor_->nz);
    for (size_t j = 0; j < factor_->n; ++j) nz += cnt[j];
    return nz;
  }

  bool IsSupernodal() const override { return factor_ && factor_->is_super; }

  void SetBlockOrdering(const std::vector<int>& block_perm) override { given_ = block_perm; }
  std::vector<int> BlockOrdering() const override { return used_; }

 private:
  void Release(bool keep_pattern = false) {
    in_place_ = false;
    if (factor_) cholmod_free_factor(&factor_, common_.get());
    if (a_ && !keep_pattern) cholmod_free_sparse(&a_, common_.get());
    if (permuted_) cholmod_free_sparse(&permuted_, common_.get());
    for (cholmod_dense** d : {&b_, &x_, &y_, &e_})
      if (*d) cholmod_free_dense(d, common_.get());
  }

  void SetPattern(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows) {
    n_ = n;
    a_ = cholmod_allocate_sparse(n, n, rows.size(), /*sorted=*/1, /*packed=*/1, /*stype=*/1,
                                 CHOLMOD_REAL, common_.get());
    if (!a_) throw std::runtime_error("CHOLMOD: out of memory allocating the normal matrix");
    std::memcpy(a_->p, col_ptr.data(), sizeof(int) * (n + 1));
    std::memcpy(a_->i, rows.data(), sizeof(int) * rows.size());
    std::memset(a_->x, 0, sizeof(double) * rows.size());
  }

  // cholmod_factorize would permute (and transpose) A into a fresh matrix
  // at every call: two transposes for the simplicial method, one for the
  // supernodal, and their allocations. Instead the permuted matrix (by
  // perm_, which holds CHOLMOD's postorder) is laid out here once, in the
  // triangle each method reads without copying, and each factorisation only
  // scatters the values into it; its symbolic factor needs no ordering.
  // `method`: CHOLMOD_AUTO to let CHOLMOD choose (the layout stays the
  // simplicial one), else supernodal_ says; `known_nonzeros`: L's, from
  // that choice's analysis (CholmodCommon::Analyze).
  void AnalyzePermuted(const std::vector<int>& rows, const std::vector<int>& col_ptr,
                       int method = -1, double known_nonzeros = -1) {
    const int n = n_;
    std::vector<int> inverse(n);
    for (int k = 0; k < n; ++k) inverse[perm_[k]] = k;
    // The simplicial method reads the upper triangle, the supernodal the lower.
    permuted_ =
        LocalPattern(col_ptr, rows, inverse, n, /*upper=*/!supernodal_, &scatter_, common_.get());
    // Already in the fill-reducing order (postordered): analysed as is.
    common_->method[0].ordering = CHOLMOD_NATURAL;
    common_->postorder = 0;
    common_->supernodal = method == CHOLMOD_AUTO ? CHOLMOD_AUTO
                         : supernodal_          ? CHOLMOD_SUPERNODAL
                                                : CHOLMOD_SIMPLICIAL;
    // CHOLMOD's own choice is redone on the other layout when supernodal.
    factor_ = method == CHOLMOD_AUTO
                  ? cholmod_analyze(permuted_, common_.get())
                  : common_.Analyze(permuted_, CholmodCommon::kFineSupernodesMinNonZeros,
                                    known_nonzeros);
    if (!factor_) throw std::runtime_error("CHOLMOD: symbolic analysis failed");
    b_ = cholmod_allocate_dense(n, 1, n, CHOLMOD_REAL, common_.get());
  }

  // A fill-reducing order of the block graph (or the given block ordering), postordered and
  // expanded to scalars; empty when not blocked.
  std::vector<int> ScalarOrdering(int n, const std::vector<int>& col_ptr,
                                  const std::vector<int>& rows,
                                  const std::vector<int>& block_sizes) {
    if (block_sizes.size() < 2) return {};
    const BlockPattern pattern = MakeBlockPattern(n, col_ptr, rows, block_sizes);
    std::vector<int> order = given_;
    if (static_cast<int>(order.size()) != pattern.blocks())
      order = FillReducingBlockOrder(pattern, common_.get());
    if (order.empty()) return {};
    used_ = Postordered(order, pattern);
    return ExpandBlocks(used_, pattern);
  }

  std::vector<int> given_, used_;

  CholmodCommon common_;
  cholmod_sparse* a_ = nullptr;         // H as the caller lays it out
  cholmod_sparse* permuted_ = nullptr;  // P H P' in the triangle the method reads
  std::vector<int> perm_;               // row k of permuted_ is row perm_[k] of H
  std::vector<int> scatter_;            // entry k of a_ goes to scatter_[k] of permuted_
  cholmod_factor* factor_ = nullptr;
  bool supernodal_ = false;
  bool in_place_ = false;  // the caller writes into permuted_ (TakeValuesInPlace)
  int mode_ = CHOLMOD_AUTO;  // as asked: supernodal, simplicial or CHOLMOD's choice
  cholmod_dense *b_ = nullptr, *x_ = nullptr, *y_ = nullptr, *e_ = nullptr;
  int n_ = 0;
};

class EigenLDLT final : public SparseCholesky {
 public:
  void Analyze(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
               const std::vector<int>&) override {
    a_.resize(n, n);
    a_.resizeNonZeros(static_cast<Eigen::Index>(rows.size()));
    std::memcpy(a_.outerIndexPtr(), col_ptr.data(), sizeof(int) * (n + 1));
    std::memcpy(a_.innerIndexPtr(), rows.data(), sizeof(int) * rows.size());
    std::fill(a_.valuePtr(), a_.valuePtr() + rows.size(), 0.0);
    ldlt_.analyzePattern(a_);
  }
  double* values() override { return a_.valuePtr(); }
  bool Factorize() override {
    ldlt_.factorize(a_);
    if (ldlt_.info() != Eigen::Success) return false;
    nnz_ = ldlt_.matrixL().nestedExpression().nonZeros();
    return (ldlt_.vectorD().array() > 0).all();
  }
  void Solve(const double* b, double* x) override {
    Eigen::Map<Eigen::VectorXd>(x, a_.rows()) =
        ldlt_.solve(Eigen::Map<const Eigen::VectorXd>(b, a_.rows()));
  }
  long FactorNonZeros() const override { return nnz_; }
  bool IsSupernodal() const override { return false; }

 private:
  // Eigen's IndexType int matches CHOLMOD's, so one pattern serves both.
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> a_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Upper> ldlt_;
  long nnz_ = 0;
};

}  // namespace

std::unique_ptr<SparseCholesky> SparseCholesky::Create(Factorization kind) {
  switch (kind) {
    case Factorization::kSupernodal: return std::make_unique<Cholmod>(CHOLMOD_SUPERNODAL);
    case Factorization::kSimplicial: return std::make_unique<Cholmod>(CHOLMOD_SIMPLICIAL);
    case Factorization::kSupernodalOrSimplicial: return std::make_unique<Cholmod>(CHOLMOD_AUTO);
    case Factorization::kEigenLDLT: return std::make_unique<EigenLDLT>();
  }
  return nullptr;
}

}  // namespace cairn
