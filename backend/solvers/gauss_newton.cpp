#include "cairn/solvers/gauss_newton.h"

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <thread>

#include "cairn/graph/runtime.h"
#include "cairn/linear/conjugate_gradients.h"
#include "cairn/linear/domain_cholesky.h"
#include "cairn/linear/parallel.h"
#include "cairn/linear/sparse_cholesky.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/linear/sparse_qr.h"

namespace cairn {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Blocks and residuals are records of a million or more on a large graph:
// their fields are as narrow as their ranges allow (32 and 20 bytes, where
// pointers and owned objects in each had made them 40 and 48).
struct GaussNewtonProblem::Block {
  double* values;
  const ceres::Manifold* manifold;
  uint16_t size;     // ambient
  uint16_t tangent;  // local
  int offset = -1;  // first row of this block in H; -1 when constant
  int variable = -1;
  bool constant = false;
};

struct GaussNewtonProblem::Residual {
  uint32_t source = 0;      // into sources_
  uint32_t member = 0;      // a family's member
  int32_t first_block = 0;  // its blocks are residual_blocks_[first_block, + arity)
  uint16_t arity = 0;
  uint16_t m = 0;     // residuals
  int32_t loss = -1;  // into losses_; -1: none
};

// What evaluates residuals: a cost function of one residual's own, or a
// family shared by a run of them.
struct GaussNewtonProblem::Source {
  std::unique_ptr<ceres::CostFunction> cost;
  const ResidualFamily* family = nullptr;
};

namespace {

// Members of a group evaluated by one thread in a row, their chi2 summed:
// a residual costs 1-5 us, waking the other threads for a group about as
// much as a few dozen.
constexpr size_t kChi2Run = 32;

template <typename T>
T Narrow(size_t value, const char* what) {
  if (value > std::numeric_limits<T>::max())
    throw std::length_error(std::string("too many ") + what + " for the Gauss-Newton problem");
  return static_cast<T>(value);
}

}  // namespace

bool GaussNewtonProblem::EvaluateOf(const Residual& r, const double* const* params, double* out,
                                    double** jacobians) const {
  const Source& s = sources_[r.source];
  return s.cost ? s.cost->Evaluate(params, out, jacobians)
                : s.family->Evaluate(r.member, params, out, jacobians);
}

const ceres::LossFunction* GaussNewtonProblem::LossOf(const Residual& r) const {
  return r.loss < 0 ? nullptr : losses_[r.loss].get();
}

// Everything a solve needs, allocated once before the first iteration.
struct GaussNewtonProblem::Workspace {
  // Per residual: its values. Its local Jacobians are kept (keep_jacobians)
  // when they take at most max_kept_jacobian_bytes, or for kQR's A: slot
  // slot_start[k] + p, residual k's p-th parameter block, at jac_local_off
  // (-1 for a constant block). b and H are then gathered from them, part by
  // part. Otherwise they live only in a worker's scratch while they add to b
  // and H, group by group (below).
  bool keep_jacobians = false;
  int residual_rows = 0, max_rows = 1;  // all residuals' rows, one residual's most
  std::vector<int> residual_offset;  // into r, which is kept with the Jacobians
  std::vector<int> slot_start, jac_local_off;
  std::vector<double> r, jac_local;
  size_t max_ambient = 1;  // the most doubles one residual's ambient Jacobians take
  size_t max_local = 1;    // ... and its local ones
  // chi2 summed in a fixed order whatever the thread count: per residual
  // (rho(|r|^2)) with the Jacobians kept; without, per run of kChi2Run
  // members of a group, in group order.
  std::vector<double> chi2_terms;
  // Per variable block: the manifold's PlusJacobian (size x tangent) at
  // plus_jac_off, computed once a linearisation. Without the Jacobians kept,
  // one of at most kRecomputedPlus doubles (2D: 3x3, 72 MB at a million
  // poses) is not kept (offset -1): each residual takes its blocks' again,
  // in a worker's scratch. A 3D pose's 7x6 is kept: taken again for each
  // residual, its autodiff made a 200,000-pose solve's linearisations 1.8 s
  // (about 40%) longer.
  static constexpr int kRecomputedPlus = 9;
  std::vector<int> plus_jac_off;
  std::vector<double> plus_jac;
  // H's upper triangle, block by block: for block (r, c) with r <= c,
  // col_start[s + j] is where column j of the block begins in the values,
  // at the first row of block r (s: the block's start, below).
  std::vector<int> col_start;
  // Residuals in groups none of whose members share a variable: a group's
  // members add to H and b at once without locks, and each sum runs in group
  // order whatever the thread count. Group g is by_group[group_start[g] ...
  // group_start[g + 1]).
  std::vector<int> group_start, by_group;
  // For each pair p < q of a residual's variable slots, in that order from
  // pair_start[k]: the start of the block of H it adds to, with kOpens set
  // on the pair that reaches the block first (in group order), which writes
  // it instead of adding: H is never cleared.
  static constexpr uint32_t kOpens = 1u << 31;
  std::vector<int> pair_start;
  std::vector<uint32_t> pair_place;
  // With the Jacobians kept: per variable v, gradient_terms[gradient_start[v]
  // ...] are the (residual, p) whose J_p^T r add to its part of b; per block
  // of H, the terms Jp^T Jq (offsets in jac_local, m rows) it sums.
  std::vector<int> gradient_start;
  std::vector<std::pair<int, int>> gradient_terms;
  struct Contribution {
    int jp, jq, m;
  };
  struct KeptBlock {
    int row_block, col_block, start;  // start: index into col_start
    int term_begin, term_end;         // its contributions, in `terms`
  };
  std::vector<KeptBlock> kept_blocks;
  std::vector<Contribution> terms;
  // The diagonal blocks, which every residual adds to, summed here (each
  // variable's upper triangle, by columns, from diagonal_sum_start[v]) and
  // written to H once: added where the factorisation keeps them, one
  // residual at a time, the linearisations of a million-pose 2D solve took
  // 8.0 s instead of 6.1.
  std::vector<int> diagonal_sum_start;
  std::vector<double> diagonal_sum;
  std::vector<int> diagonal;  // value index of each H(i, i)
  std::vector<double> diagonal_saved;
  // The least damping any diagonal entry gets, relative to the largest, so
  // that a zero entry is damped too whatever the scale of the information.
  double damping_floor = 0;
  std::vector<double> b, dx, x_saved, b_saved;
  std::unique_ptr<SparseCholesky> cholesky;  // null for kQR
  // H's values where the factorisation reads them (places.index empty:
  // in h_values, the caller's layout).
  ValuePlaces places;
  double* h_values = nullptr;
  bool HasH() const { return !places.index.empty() || h_values; }
  double& H(size_t k) { return places.index.empty() ? h_values[k] : places[k]; }
  // `relative` times the largest of diagonal_saved, once that holds the
  // undamped diagonal.
  void SetDampingFloor(double relative) {
    double largest = 0;
    for (int i = 0; i < n; ++i) largest = std::max(largest, diagonal_saved[i]);
    damping_floor = relative * largest;
  }
  // kQR: A = [J; sqrt(lambda D)] in compressed columns, each column's
  // Jacobian entries then its damping row; for each of A's values its
  // index in jac_local (-1: the damping row), and where each column begins.
  std::unique_ptr<SparseQR> qr;
  std::vector<int> qr_source, qr_col_ptr;
  std::vector<double> qr_rhs;
  std::vector<int> variables;  // non-constant blocks, in H's order
  CholeskyKind linear_solver = CholeskyKind::kAuto;
  double factor_memory_bytes = -1;  // GaussNewtonOptions::factor_memory_bytes
  int n = 0;
  int max_tangent = 1, max_size = 1;
  size_t max_arity = 1;
};

// A block of H's upper triangle while its pattern is planned.
struct GaussNewtonProblem::HBlock {
  int row_block, col_block;
  int start;  // index into col_start
};

GaussNewtonProblem::GaussNewtonProblem() = default;
GaussNewtonProblem::~GaussNewtonProblem() = default;

int GaussNewtonProblem::TangentDimension() const { return ws_ ? ws_->n : 0; }
long GaussNewtonProblem::FactorNonZeros() const {
  if (!ws_) return 0;
  if (ws_->qr) return ws_->qr->FactorNonZeros();
  return ws_->cholesky ? ws_->cholesky->FactorNonZeros() : 0;
}
CholeskyKind GaussNewtonProblem::LinearSolver() const {
  return ws_ ? ws_->linear_solver : CholeskyKind::kAuto;
}

int GaussNewtonProblem::NumParameterBlocks() const { return static_cast<int>(blocks_.size()); }
int GaussNewtonProblem::NumResidualBlocks() const { return static_cast<int>(residuals_.size()); }

void GaussNewtonProblem::Reserve(size_t blocks, size_t residuals) {
  blocks_.reserve(blocks);
  block_index_.reserve(blocks);
  residuals_.reserve(residuals);
  residual_blocks_.reserve(2 * residuals);
}

void GaussNewtonProblem::AddParameterBlock(double* values, int size,
                                           const ceres::Manifold* manifold) {
  auto it = block_index_.find(values);
  if (it != block_index_.end()) {
    Block& b = blocks_[it->second];
    if (b.size != size) throw std::invalid_argument("parameter block re-added with another size");
    if (manifold) {
      b.manifold = manifold;
      b.tangent = manifold->TangentSize();
    }
    return;
  }
  if (manifold && manifold->AmbientSize() != size)
    throw std::invalid_argument("manifold's ambient size differs from the block's size");
  if (size < 0) throw std::invalid_argument("a parameter block of negative size");
  const auto tangent = Narrow<uint16_t>(manifold ? manifold->TangentSize() : size, "parameters in a block");
  block_index_.emplace(values, static_cast<int>(blocks_.size()));
  blocks_.push_back(Block{values, manifold, Narrow<uint16_t>(size, "parameters in a block"), tangent});
}

void GaussNewtonProblem::SetParameterBlockConstant(double* values) {
  auto it = block_index_.find(values);
  if (it == block_index_.end()) throw std::invalid_argument("unknown parameter block");
  blocks_[it->second].constant = true;
}

void GaussNewtonProblem::AddResidualBlock(ceres::CostFunction* cost, ceres::LossFunction* loss,
                                          const std::vector<double*>& blocks) {
  std::unique_ptr<ceres::CostFunction> owned(cost);
  std::unique_ptr<ceres::LossFunction> owned_loss(loss);
  const auto& sizes = cost->parameter_block_sizes();
  if (sizes.size() != blocks.size())
    throw std::invalid_argument("cost function takes a different number of parameter blocks");
  Residual r;
  r.m = Narrow<uint16_t>(cost->num_residuals(), "residuals in a block");
  r.source = Narrow<uint32_t>(sources_.size(), "cost functions");
  sources_.push_back(Source{std::move(owned), nullptr});
  AddResidual(r, std::move(owned_loss), blocks, std::vector<int>(sizes.begin(), sizes.end()));
}

void GaussNewtonProblem::AddResidualBlock(const ResidualFamily* family, size_t member,
                                          ceres::LossFunction* loss,
                                          const std::vector<double*>& blocks,
                                          const std::vector<int>& block_sizes) {
  std::unique_ptr<ceres::LossFunction> owned_loss(loss);
  if (block_sizes.size() != blocks.size())
    throw std::invalid_argument("a residual's blocks and their sizes differ in number");
  Residual r;
  r.member = Narrow<uint32_t>(member, "members of a residual family");
  r.m = Narrow<uint16_t>(family->NumResiduals(member), "residuals in a block");
  if (sources_.empty() || sources_.back().family != family) sources_.push_back(Source{nullptr, family});
  r.source = Narrow<uint32_t>(sources_.size() - 1, "cost functions");
  AddResidual(r, std::move(owned_loss), blocks, block_sizes);
}

void GaussNewtonProblem::AddResidual(Residual r, std::unique_ptr<ceres::LossFunction> loss,
                                     const std::vector<double*>& blocks,
                                     const std::vector<int>& sizes) {
  r.first_block = Narrow<int32_t>(residual_blocks_.size(), "blocks of all residuals");
  r.arity = Narrow<uint16_t>(blocks.size(), "blocks in a residual");
  for (size_t k = 0; k < blocks.size(); ++k) {
    AddParameterBlock(blocks[k], sizes[k]);
    residual_blocks_.push_back(block_index_.at(blocks[k]));
  }
  if (loss) {
    r.loss = Narrow<int32_t>(losses_.size(), "loss functions");
    losses_.push_back(std::move(loss));
  }
  residuals_.push_back(r);
}

GaussNewtonProblem::BlockList GaussNewtonProblem::BlocksOf(const Residual& r) const {
  return BlockList{residual_blocks_.data() + r.first_block, static_cast<size_t>(r.arity)};
}

namespace {

// The caller's choice made concrete, for a solver of `threads` threads.
std::unique_ptr<SparseCholesky> CreateFactorization(CholeskyKind kind, int threads,
                                                    double factor_memory_bytes) {
  switch (kind) {
    case CholeskyKind::kAuto:
      return CreateFactorization(ResolveCholeskyKind(kind, threads), threads, factor_memory_bytes);
    case CholeskyKind::kTwoHalves:
      return CreateDomainCholesky(kMinWorkToSplit, threads, -1, factor_memory_bytes);
    case CholeskyKind::kSupernodal: return SparseCholesky::Create(Factorization::kSupernodal);
    case CholeskyKind::kSimplicial: return SparseCholesky::Create(Factorization::kSimplicial);
    case CholeskyKind::kSupernodalOrSimplicial:
      return SparseCholesky::Create(Factorization::kSupernodalOrSimplicial);
    case CholeskyKind::kEigenLDLT: return SparseCholesky::Create(Factorization::kEigenLDLT);
    case CholeskyKind::kConjugateGradients: return CreateConjugateGradients();
    case CholeskyKind::kConjugateGradientsJacobi: {
      ConjugateGradientsOptions o;
      o.preconditioner = Preconditioner::kBlockJacobi;
      return CreateConjugateGradients(o);
    }
    case CholeskyKind::kQR: break;  // not a factorisation of H: PlanJacobian
  }
  return nullptr;
}

// Chord steps start once a full step lowers chi2 by less than this fraction:
// by then the problem is close to quadratic and H changes little.
constexpr double kChordThreshold = 2e-2;
// A chord step is followed by another only if its decrease is at most this
// share of the step's before it.
constexpr double kChordContraction = 0.5;
// Ceres's defaults: a step must achieve this share of the decrease its
// linear model predicted, and the trust region stays within [1e-32, 1e16].
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kMinDamping = 1e-16, kMaxDamping = 1e32;
constexpr double kRelativeDampingFloor = 1e-16;

// The small dense products of the inner loops, with sizes known at compile
// time for the poses' blocks (2D: 3 residuals, 3 parameters, 3 tangent; 3D:
// 6, 7, 6), where Eigen unrolls them; any other size takes the general path.
// On city10000 the general path spent more in these products than in the
// factors' autodiff.
// Landmark observations (2D: 2 residuals on a pose and a 2-point; 3D: 3 on
// a pose and a 3-point) get fixed sizes too, tried after the poses' so that
// a pose graph's products take the branches they always took.
template <int M, int S, int T>
void LocalJacobianFixed(const double* ja, const double* plus, double* jl) {
  Eigen::Map<Eigen::Matrix<double, M, T, Eigen::RowMajor>>(jl).noalias() =
      Eigen::Map<const Eigen::Matrix<double, M, S, Eigen::RowMajor>>(ja) *
      Eigen::Map<const Eigen::Matrix<double, S, T, Eigen::RowMajor>>(plus);
}

template <int M, int T>
void AddGradientFixed(const double* jp, const double* r, double* g) {
  Eigen::Map<Eigen::Matrix<double, T, 1>>(g).noalias() +=
      Eigen::Map<const Eigen::Matrix<double, M, T, Eigen::RowMajor>>(jp).transpose() *
      Eigen::Map<const Eigen::Matrix<double, M, 1>>(r);
}

template <int M, int R, int C>
void AddOuterFixed(const double* jp, const double* jq, double* acc, int ld) {
  Eigen::Map<Eigen::Matrix<double, R, C>, 0, Eigen::OuterStride<>>(acc, R, C,
                                                                   Eigen::OuterStride<>(ld))
      .noalias() += Eigen::Map<const Eigen::Matrix<double, M, R, Eigen::RowMajor>>(jp).transpose() *
                    Eigen::Map<const Eigen::Matrix<double, M, C, Eigen::RowMajor>>(jq);
}

// The landmark shapes of AddOuter: m residual rows, blocks of a pose's
// tangent size `pose` or a point's `m`. False for any other shape.
template <int M, int P>
bool AddLandmarkOuter(const double* jp, const double* jq, double* acc, int ld, int tr, int tc) {
  if (tr == P && tc == P) {
    AddOuterFixed<M, P, P>(jp, jq, acc, ld);
  } else if (tr == P && tc == M) {
    AddOuterFixed<M, P, M>(jp, jq, acc, ld);
  } else if (tr == M && tc == P) {
    AddOuterFixed<M, M, P>(jp, jq, acc, ld);
  } else if (tr == M && tc == M) {
    AddOuterFixed<M, M, M>(jp, jq, acc, ld);
  } else {
    return false;
  }
  return true;
}

// jl = ja * plus: the local (tangent) Jacobian, m x t, from the ambient one.
void LocalJacobian(const double* ja, const double* plus, double* jl, int m, int size, int t) {
  if (m == 3 && size == 3 && t == 3) {
    using J = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    Eigen::Map<J>(jl).noalias() = Eigen::Map<const J>(ja) * Eigen::Map<const J>(plus);
  } else if (m == 6 && size == 7 && t == 6) {
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(jl).noalias() =
        Eigen::Map<const Eigen::Matrix<double, 6, 7, Eigen::RowMajor>>(ja) *
        Eigen::Map<const Eigen::Matrix<double, 7, 6, Eigen::RowMajor>>(plus);
  } else if (m == 2 && size == 3 && t == 3) {
    LocalJacobianFixed<2, 3, 3>(ja, plus, jl);
  } else if (m == 3 && size == 7 && t == 6) {
    LocalJacobianFixed<3, 7, 6>(ja, plus, jl);
  } else {
    Eigen::Map<RowMatrix>(jl, m, t).noalias() =
        Eigen::Map<const RowMatrix>(ja, m, size) * Eigen::Map<const RowMatrix>(plus, size, t);
  }
}

// g += jp' r, jp m x t.
void AddGradient(const double* jp, const double* r, double* g, int m, int t) {
  if (m == 3 && t == 3) {
    Eigen::Map<Eigen::Vector3d>(g).noalias() +=
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(jp).transpose() *
        Eigen::Map<const Eigen::Vector3d>(r);
  } else if (m == 6 && t == 6) {
    Eigen::Map<Eigen::Matrix<double, 6, 1>>(g).noalias() +=
        Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(jp).transpose() *
        Eigen::Map<const Eigen::Matrix<double, 6, 1>>(r);
  } else if (m == 2 && t == 3) {
    AddGradientFixed<2, 3>(jp, r, g);
  } else if (m == 2 && t == 2) {
    AddGradientFixed<2, 2>(jp, r, g);
  } else if (m == 3 && t == 6) {
    AddGradientFixed<3, 6>(jp, r, g);
  } else {
    Eigen::Map<Eigen::VectorXd>(g, t).noalias() +=
        Eigen::Map<const RowMatrix>(jp, m, t).transpose() * Eigen::Map<const Eigen::VectorXd>(r, m);
  }
}

// acc (tr x tc, column-major with leading dimension ld) += jp' jq.
void AddOuter(const double* jp, const double* jq, double* acc, int ld, int m, int tr, int tc) {
  if (m == 3 && tr == 3 && tc == 3) {
    using J = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    Eigen::Map<Eigen::Matrix3d, 0, Eigen::OuterStride<>>(acc, 3, 3, Eigen::OuterStride<>(ld))
        .noalias() += Eigen::Map<const J>(jp).transpose() * Eigen::Map<const J>(jq);
  } else if (m == 6 && tr == 6 && tc == 6) {
    using J = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
    Eigen::Map<Eigen::Matrix<double, 6, 6>, 0, Eigen::OuterStride<>>(acc, 6, 6,
                                                                     Eigen::OuterStride<>(ld))
        .noalias() += Eigen::Map<const J>(jp).transpose() * Eigen::Map<const J>(jq);
  } else if (!(m == 2 && AddLandmarkOuter<2, 3>(jp, jq, acc, ld, tr, tc)) &&
             !(m == 3 && AddLandmarkOuter<3, 6>(jp, jq, acc, ld, tr, tc))) {
    Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>(acc, tr, tc, Eigen::OuterStride<>(ld))
        .noalias() += Eigen::Map<const RowMatrix>(jp, m, tr).transpose() *
                      Eigen::Map<const RowMatrix>(jq, m, tc);
  }
}

double MaxAbs(const std::vector<double>& v, int n) {
  return n > 0 ? Eigen::Map<const Eigen::VectorXd>(v.data(), n).cwiseAbs().maxCoeff() : 0.0;
}

double RhoOf(const ceres::LossFunction* loss, double s, double* weight) {
  if (!loss) {
    if (weight) *weight = 1.0;
    return s;
  }
  double rho[3];
  loss->Evaluate(s, rho);
  if (weight) *weight = rho[1];
  return rho[0];
}

}  // namespace

double GaussNewtonProblem::Chi2() {
  double sum = 0;
  std::vector<double> r;
  std::vector<const double*> params;
  for (const Residual& res : residuals_) {
    r.resize(res.m);
    params.clear();
    for (int b : BlocksOf(res)) params.push_back(blocks_[b].values);
    if (!EvaluateOf(res, params.data(), r.data(), nullptr))
      return std::numeric_limits<double>::quiet_NaN();
    double s = 0;
    for (double v : r) s += v * v;
    sum += RhoOf(LossOf(res), s, nullptr);
  }
  return sum;
}

// The analysis of the last Prepare, kept for one that may extend it.
struct GaussNewtonProblem::PreviousAnalysis {
  std::unique_ptr<SparseCholesky> cholesky;
  std::vector<int> variables;
  CholeskyKind kind = CholeskyKind::kAuto;
};

void GaussNewtonProblem::Prepare(const GaussNewtonOptions& options) {
  pool_ = std::make_unique<ThreadPool>(ResolveThreads(options.threads));
  // A caller that only added to the problem (and says so with an ordering
  // hint) keeps the old analysis, extended, when the new pattern allows.
  PreviousAnalysis previous;
  if (ws_ && ws_->cholesky && !ordering_hint_.empty()) {
    previous.cholesky = std::move(ws_->cholesky);
    previous.variables = std::move(ws_->variables);
    previous.kind = ws_->linear_solver;
  }
  last_analysis_extended_ = false;
  ws_ = std::make_unique<Workspace>();
  Workspace& w = *ws_;

  NumberVariables();
  w.linear_solver = ResolveCholeskyKind(options.linear_solver, pool_->size());
  w.factor_memory_bytes = options.factor_memory_bytes;
  const bool qr = w.linear_solver == CholeskyKind::kQR;
  w.keep_jacobians = qr || LocalJacobianDoubles() * sizeof(double) <= options.max_kept_jacobian_bytes;
  AllocateResiduals(w.keep_jacobians);
  if (w.keep_jacobians) {
    PlanGradient();
  } else {
    GroupResiduals();
  }
  w.b.resize(w.n);
  w.dx.resize(w.n);
  w.diagonal_saved.resize(w.n);
  for (int v : w.variables) w.x_saved.insert(w.x_saved.end(), blocks_[v].values, blocks_[v].values + blocks_[v].size);
  if (qr) {
    ordering_hint_.clear();  // SuiteSparseQR orders J's columns itself
    PlanJacobian();          // H is never formed
    return;
  }

  std::vector<int> col_ptr, rows;
  {
    std::vector<HBlock> h_blocks;
    std::vector<int> pair_block;
    const std::vector<int> col_blocks = PlanNormalMatrix(&h_blocks, &pair_block);
    PlanPattern(col_blocks, &h_blocks, &col_ptr, &rows);
    if (w.keep_jacobians) {
      PlanKeptTerms(h_blocks, pair_block);
    } else {
      PlacePairs(h_blocks, pair_block);
    }
  }
  AnalyzePattern(&previous, col_ptr, rows);
  if (w.cholesky && w.n > 0 && !w.cholesky->TakeValuesInPlace(&w.places)) {
    w.places = ValuePlaces();
    w.h_values = w.cholesky->values();
  }
}

// Variables: non-constant blocks that some residual touches, in order.
void GaussNewtonProblem::NumberVariables() {
  Workspace& w = *ws_;
  std::vector<bool> used(blocks_.size(), false);
  for (const Residual& r : residuals_)
    for (int b : BlocksOf(r)) used[b] = true;
  std::vector<int>& variables = w.variables;
  for (size_t i = 0; i < blocks_.size(); ++i) {
    Block& b = blocks_[i];
    b.offset = -1;
    b.variable = -1;
    if (b.constant || !used[i]) continue;
    b.variable = static_cast<int>(variables.size());
    b.offset = w.n;
    w.n += b.tangent;
    variables.push_back(static_cast<int>(i));
  }
  for (const Block& b : blocks_) {
    w.max_tangent = std::max<int>(w.max_tangent, b.tangent);
    w.max_size = std::max<int>(w.max_size, b.size);
  }
  for (const Residual& r : residuals_)
    w.max_arity = std::max(w.max_arity, static_cast<size_t>(r.arity));
}

// Residual storage (the local Jacobians too, when kept), and the manifolds'
// PlusJacobians.
void GaussNewtonProblem::AllocateResiduals(bool keep_jacobians) {
  Workspace& w = *ws_;
  int r_total = 0, jl_total = 0, slots = 0;
  if (keep_jacobians) {
    w.residual_offset.resize(residuals_.size());
    w.slot_start.resize(residuals_.size() + 1);
    for (size_t k = 0; k < residuals_.size(); ++k) {
      w.slot_start[k] = slots;
      slots += residuals_[k].arity;
    }
    w.slot_start[residuals_.size()] = slots;
    w.jac_local_off.resize(slots);
  }
  for (size_t k = 0; k < residuals_.size(); ++k) {
    const int m = residuals_[k].m;
    if (keep_jacobians) w.residual_offset[k] = r_total;
    r_total += m;
    w.max_rows = std::max(w.max_rows, m);
    size_t ambient = 0, local = 0;
    const BlockList rb = BlocksOf(residuals_[k]);
    for (size_t p = 0; p < rb.size(); ++p) {
      const Block& blk = blocks_[rb[p]];
      if (keep_jacobians)
        w.jac_local_off[w.slot_start[k] + p] = blk.variable >= 0 ? jl_total + static_cast<int>(local) : -1;
      if (blk.variable < 0) continue;
      ambient += static_cast<size_t>(m) * blk.size;
      local += static_cast<size_t>(m) * blk.tangent;
    }
    if (keep_jacobians) jl_total += static_cast<int>(local);
    w.max_ambient = std::max(w.max_ambient, ambient);
    w.max_local = std::max(w.max_local, local);
  }
  w.residual_rows = r_total;
  if (keep_jacobians) w.r.resize(r_total);
  w.jac_local.resize(jl_total);
  if (keep_jacobians) w.chi2_terms.resize(residuals_.size());  // else the groups size it
  const int nvar = static_cast<int>(w.variables.size());
  w.plus_jac_off.assign(nvar, -1);
  int pj_total = 0;
  for (int v = 0; v < nvar; ++v) {
    const Block& b = blocks_[w.variables[v]];
    const int doubles = b.size * b.tangent;
    if (!b.manifold || (!keep_jacobians && doubles <= Workspace::kRecomputedPlus)) continue;
    w.plus_jac_off[v] = pj_total;
    pj_total += doubles;
  }
  w.plus_jac.resize(pj_total);
}

// f(residual, p, variable) for each parameter block p of each residual that
// is a variable.
template <typename F>
void GaussNewtonProblem::ForEachSlot(F&& f) const {
  for (size_t k = 0; k < residuals_.size(); ++k) {
    const BlockList rb = BlocksOf(residuals_[k]);
    for (size_t p = 0; p < rb.size(); ++p) {
      const int vp = blocks_[rb[p]].variable;
      if (vp >= 0) f(static_cast<int>(k), static_cast<int>(p), vp);
    }
  }
}

// f(vp, vq, p, q) for each pair of residual k's slots p < q that are
// variables, in that order; H(min, max) gains their term. A block listed
// twice in one residual adds only its own diagonal term.
template <typename F>
void GaussNewtonProblem::ForEachPairOf(size_t k, F&& f) const {
  const BlockList rb = BlocksOf(residuals_[k]);
  for (size_t p = 0; p < rb.size(); ++p) {
    const int vp = blocks_[rb[p]].variable;
    if (vp < 0) continue;
    for (size_t q = p + 1; q < rb.size(); ++q) {
      const int vq = blocks_[rb[q]].variable;
      if (vq < 0 || vq == vp) continue;
      f(vp, vq, static_cast<int>(p), static_cast<int>(q));
    }
  }
}

// f(residual, pair, vp, vq) for every residual's pairs, numbered in order.
template <typename F>
void GaussNewtonProblem::ForEachPair(F&& f) const {
  int pair = 0;
  for (size_t k = 0; k < residuals_.size(); ++k)
    ForEachPairOf(k, [&](int vp, int vq, int, int) { f(static_cast<int>(k), pair++, vp, vq); });
}

size_t GaussNewtonProblem::LocalJacobianDoubles() const {
  size_t total = 0;
  for (const Residual& res : residuals_)
    for (int b : BlocksOf(res))
      if (blocks_[b].variable >= 0) total += static_cast<size_t>(res.m) * blocks_[b].tangent;
  return total;
}

void GaussNewtonProblem::PlanGradient() {
  Workspace& w = *ws_;
  const int nvar = static_cast<int>(w.variables.size());
  w.gradient_start.assign(nvar + 1, 0);
  ForEachSlot([&](int, int, int vp) { ++w.gradient_start[vp + 1]; });
  for (int v = 0; v < nvar; ++v) w.gradient_start[v + 1] += w.gradient_start[v];
  w.gradient_terms.resize(w.gradient_start[nvar]);
  std::vector<int> next(w.gradient_start.begin(), w.gradient_start.end() - 1);
  ForEachSlot([&](int k, int p, int vp) { w.gradient_terms[next[vp]++] = {k, p}; });
}

// With the Jacobians kept: each block of H and its terms, in residual order
// (so sums do not depend on how the pattern was found).
void GaussNewtonProblem::PlanKeptTerms(const std::vector<HBlock>& h_blocks,
                                       const std::vector<int>& pair_block) {
  Workspace& w = *ws_;
  const int nvar = static_cast<int>(w.variables.size());
  // The diagonal block of a column is the last of its blocks.
  std::vector<int> diagonal_block(nvar);
  for (size_t i = 0; i < h_blocks.size(); ++i)
    if (h_blocks[i].row_block == h_blocks[i].col_block) diagonal_block[h_blocks[i].col_block] = static_cast<int>(i);
  std::vector<int> begin(h_blocks.size() + 1, 0);
  ForEachSlot([&](int, int, int vp) { ++begin[diagonal_block[vp] + 1]; });
  for (int t : pair_block) ++begin[t + 1];
  for (size_t i = 0; i < h_blocks.size(); ++i) begin[i + 1] += begin[i];
  w.terms.resize(begin.back());
  std::vector<int> next(begin.begin(), begin.end() - 1);
  auto offset = [&](int k, int p) { return w.jac_local_off[w.slot_start[k] + p]; };
  // Residual by residual, its diagonal terms then its pairs.
  size_t pair = 0;
  for (size_t k = 0; k < residuals_.size(); ++k) {
    const int m = residuals_[k].m;
    const BlockList rb = BlocksOf(residuals_[k]);
    for (size_t p = 0; p < rb.size(); ++p) {
      const int vp = blocks_[rb[p]].variable;
      if (vp < 0) continue;
      const int o = offset(static_cast<int>(k), static_cast<int>(p));
      w.terms[next[diagonal_block[vp]]++] = Workspace::Contribution{o, o, m};
    }
    ForEachPairOf(k, [&](int vp, int vq, int p, int q) {
      const int op = offset(static_cast<int>(k), p), oq = offset(static_cast<int>(k), q);
      w.terms[next[pair_block[pair++]]++] =
          vp < vq ? Workspace::Contribution{op, oq, m} : Workspace::Contribution{oq, op, m};
    });
  }
  w.kept_blocks.resize(h_blocks.size());
  for (size_t i = 0; i < h_blocks.size(); ++i)
    w.kept_blocks[i] = Workspace::KeptBlock{h_blocks[i].row_block, h_blocks[i].col_block,
                                            h_blocks[i].start, begin[i], begin[i + 1]};
}

// Greedy, residuals in order: each joins the lowest group that none of its
// variables is in yet. The first 64 groups are tracked by a mask per
// variable; once those are all taken (a landmark seen from many poses), the
// group after the highest its variables are in.
void GaussNewtonProblem::GroupResiduals() {
  Workspace& w = *ws_;
  const size_t nres = residuals_.size();
  std::vector<uint64_t> in_group(w.variables.size(), 0);
  std::vector<int> beyond(w.variables.size(), 64);
  std::vector<int> group(nres);
  int groups = 0;
  for (size_t k = 0; k < nres; ++k) {
    uint64_t taken = 0;
    int next = 64;
    for (int b : BlocksOf(residuals_[k])) {
      const int v = blocks_[b].variable;
      if (v < 0) continue;
      taken |= in_group[v];
      next = std::max(next, beyond[v]);
    }
    const int g = ~taken ? __builtin_ctzll(~taken) : next;
    for (int b : BlocksOf(residuals_[k])) {
      const int v = blocks_[b].variable;
      if (v < 0) continue;
      if (g < 64) in_group[v] |= uint64_t{1} << g;
      else beyond[v] = g + 1;
    }
    group[k] = g;
    groups = std::max(groups, g + 1);
  }
  w.group_start.assign(groups + 1, 0);
  for (int g : group) ++w.group_start[g + 1];
  for (int g = 0; g < groups; ++g) w.group_start[g + 1] += w.group_start[g];
  w.by_group.resize(nres);
  std::vector<int> next(w.group_start.begin(), w.group_start.end() - 1);
  for (size_t k = 0; k < nres; ++k) w.by_group[next[group[k]]++] = static_cast<int>(k);
  size_t runs = 0;
  for (int g = 0; g < groups; ++g)
    runs += (w.group_start[g + 1] - w.group_start[g] + kChi2Run - 1) / kChi2Run;
  w.chi2_terms.resize(runs);
}

// The blocks of H's upper triangle, by column block then row block (the
// diagonal block last); returns, per column block c, where its blocks begin
// in h_blocks (entry c + 1: where they end). pair_block: the block each pair
// of ForEachPair adds to.
std::vector<int> GaussNewtonProblem::PlanNormalMatrix(std::vector<HBlock>* h_blocks,
                                                      std::vector<int>* pair_block) {
  Workspace& w = *ws_;
  const int nvar = static_cast<int>(w.variables.size());
  w.pair_start.assign(residuals_.size() + 1, 0);
  std::vector<int> col_entries(nvar + 1, 0);
  int pairs = 0;
  ForEachPair([&](int k, int, int vp, int vq) {
    ++w.pair_start[k + 1];
    ++col_entries[std::max(vp, vq) + 1];
    ++pairs;
  });
  for (size_t k = 0; k < residuals_.size(); ++k) w.pair_start[k + 1] += w.pair_start[k];
  for (int v = 0; v < nvar; ++v) col_entries[v + 1] += col_entries[v];
  struct Entry {
    int row, pair;
  };
  std::vector<Entry> entries(pairs);
  {
    std::vector<int> next(col_entries.begin(), col_entries.end() - 1);
    ForEachPair([&](int, int pair, int vp, int vq) {
      entries[next[std::max(vp, vq)]++] = Entry{std::min(vp, vq), pair};
    });
  }
  pair_block->resize(pairs);
  std::vector<int> col_blocks(nvar + 1, 0);
  for (int c = 0; c < nvar; ++c) {
    const auto first = entries.begin() + col_entries[c], last = entries.begin() + col_entries[c + 1];
    std::sort(first, last, [](const Entry& a, const Entry& b) { return a.row < b.row; });
    for (auto e = first; e != last;) {
      const int row = e->row;
      h_blocks->push_back(HBlock{row, c, 0});
      for (; e != last && e->row == row; ++e)
        (*pair_block)[e->pair] = static_cast<int>(h_blocks->size()) - 1;
    }
    h_blocks->push_back(HBlock{c, c, 0});  // every variable has one: some residual is on it
    col_blocks[c + 1] = static_cast<int>(h_blocks->size());
  }
  return col_blocks;
}

// The scalar CSC pattern of H's upper triangle, where each block's columns
// begin in it, and where each diagonal entry is.
void GaussNewtonProblem::PlanPattern(const std::vector<int>& col_blocks,
                                     std::vector<HBlock>* h_blocks, std::vector<int>* col_ptr,
                                     std::vector<int>* rows) {
  Workspace& w = *ws_;
  const std::vector<int>& variables = w.variables;
  const int nvar = static_cast<int>(variables.size());
  col_ptr->assign(w.n + 1, 0);
  size_t starts = 0;
  for (HBlock& hb : *h_blocks) {
    hb.start = static_cast<int>(starts);
    starts += blocks_[variables[hb.col_block]].tangent;
  }
  w.col_start.resize(starts);
  w.diagonal.resize(w.n);
  for (int c = 0; c < nvar; ++c) {
    const Block& cb = blocks_[variables[c]];
    for (int j = 0; j < cb.tangent; ++j) {
      const int col = cb.offset + j;
      (*col_ptr)[col] = static_cast<int>(rows->size());
      for (int idx = col_blocks[c]; idx < col_blocks[c + 1]; ++idx) {
        const HBlock& hb = (*h_blocks)[idx];
        const Block& rb = blocks_[variables[hb.row_block]];
        w.col_start[hb.start + j] = static_cast<int>(rows->size());
        const int height = hb.row_block == c ? j + 1 : rb.tangent;
        for (int i = 0; i < height; ++i) rows->push_back(rb.offset + i);
      }
      w.diagonal[col] = static_cast<int>(rows->size()) - 1;
    }
  }
  (*col_ptr)[w.n] = static_cast<int>(rows->size());
}

// Each pair's block start, and which pair opens each block: the first to
// reach it with the groups taken in order; room for the diagonal sums.
void GaussNewtonProblem::PlacePairs(const std::vector<HBlock>& h_blocks,
                                    const std::vector<int>& pair_block) {
  Workspace& w = *ws_;
  w.diagonal_sum_start.assign(w.variables.size() + 1, 0);
  for (size_t v = 0; v < w.variables.size(); ++v) {
    const int t = blocks_[w.variables[v]].tangent;
    w.diagonal_sum_start[v + 1] = w.diagonal_sum_start[v] + t * (t + 1) / 2;
  }
  w.diagonal_sum.resize(w.diagonal_sum_start.back());
  w.pair_place.resize(pair_block.size());
  std::vector<bool> opened(h_blocks.size(), false);
  for (int k : w.by_group)
    for (int t = w.pair_start[k]; t < w.pair_start[k + 1]; ++t) {
      const int hb = pair_block[t];
      w.pair_place[t] = static_cast<uint32_t>(h_blocks[hb].start) |
                        (opened[hb] ? 0u : Workspace::kOpens);
      opened[hb] = true;
    }
}

// kQR: the pattern of A = [J; sqrt(lambda D)] and its symbolic analysis.
// Column c of A holds the rows of every residual on c's block (residual
// order, so rows are sorted), then its damping row, m + c.
void GaussNewtonProblem::PlanJacobian() {
  Workspace& w = *ws_;
  const int m = static_cast<int>(w.r.size());
  const int nvar = static_cast<int>(w.variables.size());
  std::vector<int> rows;
  w.qr_col_ptr.assign(w.n + 1, 0);
  for (int v = 0; v < nvar; ++v) {
    const Block& b = blocks_[w.variables[v]];
    for (int j = 0; j < b.tangent; ++j) {
      w.qr_col_ptr[b.offset + j] = static_cast<int>(rows.size());
      for (int t = w.gradient_start[v]; t < w.gradient_start[v + 1]; ++t) {
        const auto [k, p] = w.gradient_terms[t];
        const int jac = w.jac_local_off[w.slot_start[k] + p];
        for (int i = 0; i < residuals_[k].m; ++i) {
          rows.push_back(w.residual_offset[k] + i);
          w.qr_source.push_back(jac + i * b.tangent + j);  // row-major, m x tangent
        }
      }
      rows.push_back(m + b.offset + j);
      w.qr_source.push_back(-1);
    }
  }
  w.qr_col_ptr[w.n] = static_cast<int>(rows.size());
  w.qr_rhs.assign(m + w.n, 0.0);
  if (w.n == 0) return;
  w.qr = std::make_unique<SparseQR>();
  w.qr->Analyze(m + w.n, w.n, w.qr_col_ptr, rows);
}

// kQR's H: J's values into A (damping rows zero),
// diag(J^T J), the columns' squared norms, which the damping scales, and
// -r: a refused candidate's evaluation overwrites r, as it leaves H alone.
void GaussNewtonProblem::LoadJacobian() {
  Workspace& w = *ws_;
  for (size_t i = 0; i < w.r.size(); ++i) w.qr_rhs[i] = -w.r[i];
  double* a = w.qr->values();
  for (int c = 0; c < w.n; ++c) {
    double sum = 0;
    for (int e = w.qr_col_ptr[c]; e < w.qr_col_ptr[c + 1]; ++e) {
      const int src = w.qr_source[e];
      a[e] = src >= 0 ? w.jac_local[src] : 0.0;
      sum += a[e] * a[e];
    }
    w.diagonal_saved[c] = sum;
  }
  w.SetDampingFloor(kRelativeDampingFloor);
}

// The symbolic analysis: the previous one extended when the variables only
// grew and the linear solver can, else a fresh one (in the hinted order, if
// any).
void GaussNewtonProblem::AnalyzePattern(PreviousAnalysis* previous, const std::vector<int>& col_ptr,
                                        const std::vector<int>& rows) {
  Workspace& w = *ws_;
  const std::vector<int>& variables = w.variables;
  std::vector<int> block_sizes;
  for (int v : variables) block_sizes.push_back(blocks_[v].tangent);
  std::unique_ptr<SparseCholesky>& kept = previous->cholesky;
  const std::vector<int>& kept_variables = previous->variables;
  if (kept && previous->kind == w.linear_solver && kept_variables.size() <= variables.size() &&
      std::equal(kept_variables.begin(), kept_variables.end(), variables.begin()) &&
      kept->Extend(w.n, col_ptr, rows, block_sizes)) {
    w.cholesky = std::move(kept);
    last_analysis_extended_ = true;
    ordering_hint_.clear();
    return;
  }
  kept.reset();
  w.cholesky = CreateFactorization(w.linear_solver, pool_->size(), w.factor_memory_bytes);
  if (!ordering_hint_.empty()) {
    w.cholesky->SetBlockOrdering(HintedOrdering());
    ordering_hint_.clear();
  }
  if (w.n > 0) w.cholesky->Analyze(w.n, col_ptr, rows, block_sizes);
}

// The variables in the hint's order, those it does not list after them.
std::vector<int> GaussNewtonProblem::HintedOrdering() const {
  const int nvar = static_cast<int>(ws_->variables.size());
  std::vector<int> perm;
  std::vector<bool> placed(nvar, false);
  for (const double* p : ordering_hint_) {
    auto it = block_index_.find(p);
    if (it == block_index_.end()) continue;
    const int v = blocks_[it->second].variable;
    if (v < 0 || placed[v]) continue;
    placed[v] = true;
    perm.push_back(v);
  }
  for (int v = 0; v < nvar; ++v)
    if (!placed[v]) perm.push_back(v);
  return perm;
}


void GaussNewtonProblem::SetParameterBlockVariable(double* values) {
  auto it = block_index_.find(values);
  if (it == block_index_.end()) throw std::invalid_argument("unknown parameter block");
  blocks_[it->second].constant = false;
}

void GaussNewtonProblem::SetOrderingHint(std::vector<const double*> order) {
  ordering_hint_ = std::move(order);
}

std::vector<const double*> GaussNewtonProblem::Ordering() const {
  std::vector<const double*> order;
  if (!ws_ || !ws_->cholesky) return order;
  for (int v : ws_->cholesky->BlockOrdering()) order.push_back(blocks_[ws_->variables[v]].values);
  return order;
}

bool GaussNewtonProblem::MarginalCovariances(const std::vector<const double*>& which,
                                             std::vector<Eigen::MatrixXd>* covariances) {
  if (!ws_) throw std::logic_error("MarginalCovariances needs Prepare first");
  Workspace& w = *ws_;
  covariances->clear();
  for (const double* p : which) {
    auto it = block_index_.find(p);
    if (it == block_index_.end()) throw std::invalid_argument("unknown parameter block");
    covariances->push_back(Eigen::MatrixXd::Zero(blocks_[it->second].tangent, blocks_[it->second].tangent));
  }
  if (w.n == 0) return true;
  Linearize();
  double step = 0;
  // Factorises H itself (lambda 0); the step it solves for is not used.
  if (!SolveStep(0.0, &step)) return false;
  std::vector<double> e(w.n, 0.0), x(w.n);
  for (size_t k = 0; k < which.size(); ++k) {
    const Block& b = blocks_[block_index_.at(which[k])];
    if (b.variable < 0) continue;
    for (int j = 0; j < b.tangent; ++j) {
      e[b.offset + j] = 1.0;
      SolveNormalEquations(e.data(), x.data());
      e[b.offset + j] = 0.0;
      for (int i = 0; i < b.tangent; ++i) (*covariances)[k](i, j) = x[b.offset + i];
    }
  }
  return true;
}



double GaussNewtonProblem::EvaluateResidual(size_t k, double* r, double* ambient, double* local) {
  Workspace& w = *ws_;
  thread_local std::vector<const double*> params;
  thread_local std::vector<double*> jac;
  if (params.size() < w.max_arity) params.resize(w.max_arity), jac.resize(w.max_arity);
  const Residual& res = residuals_[k];
  const int m = res.m;
  const BlockList rb = BlocksOf(res);
  size_t used = 0;
  for (size_t p = 0; p < rb.size(); ++p) {
    const Block& blk = blocks_[rb[p]];
    params[p] = blk.values;
    jac[p] = nullptr;
    if (local && blk.variable >= 0) {
      jac[p] = ambient + used;
      used += static_cast<size_t>(m) * blk.size;
    }
  }
  Eigen::Map<Eigen::VectorXd> rv(r, m);
  if (!EvaluateOf(res, params.data(), r, local ? jac.data() : nullptr)) {
    // No step is taken from here: the terms are zero so that H stays whole.
    rv.setZero();
    if (local) std::fill(local, local + w.max_local, 0.0);
    return std::numeric_limits<double>::infinity();
  }
  double weight;
  const ceres::LossFunction* loss = LossOf(res);
  const double chi2 = RhoOf(loss, rv.squaredNorm(), &weight);
  if (!local) return chi2;
  // Iteratively reweighted: sqrt(rho') scales residual and Jacobian.
  const double sw = std::sqrt(std::max(weight, 0.0));
  if (loss) rv *= sw;
  for (size_t p = 0; p < rb.size(); ++p) {
    if (!jac[p]) continue;
    const Block& blk = blocks_[rb[p]];
    if (blk.manifold) {
      const int kept = w.plus_jac_off[blk.variable];
      const double* plus = w.plus_jac.data() + std::max(kept, 0);
      if (kept < 0) {
        thread_local std::vector<double> own;
        own.resize(static_cast<size_t>(blk.size) * blk.tangent);
        blk.manifold->PlusJacobian(blk.values, own.data());
        plus = own.data();
      }
      LocalJacobian(jac[p], plus, local, m, blk.size, blk.tangent);
    } else {
      std::copy(jac[p], jac[p] + m * blk.size, local);
    }
    if (loss) Eigen::Map<Eigen::VectorXd>(local, m * blk.tangent) *= sw;
    if (!w.jac_local_off.empty())  // kQR keeps them for A
      std::copy(local, local + m * blk.tangent,
                w.jac_local.data() + w.jac_local_off[w.slot_start[k] + p]);
    local += m * blk.tangent;
  }
  return chi2;
}

namespace {

// sum (t x t upper triangle, by columns) += jp' jp, jp m x t.
void AddDiagonal(const double* jp, int m, int t, double* sum, double* buffer) {
  Eigen::Map<Eigen::MatrixXd> full(buffer, t, t);
  full.setZero();
  AddOuter(jp, jp, buffer, t, m, t, t);
  for (int j = 0; j < t; ++j)
    for (int i = 0; i <= j; ++i) *sum++ += full(i, j);
}

}  // namespace

// The pairs are taken as ForEachPair numbers them.
void GaussNewtonProblem::AddResidualTerms(size_t k, const double* r, const double* local,
                                          bool assemble_h, double* buffer) {
  Workspace& w = *ws_;
  const Residual& res = residuals_[k];
  const int m = res.m;
  const BlockList rb = BlocksOf(res);
  const int ld = w.max_tangent;
  int pair = w.pair_start.empty() ? 0 : w.pair_start[k];
  const double* jp = local;
  for (size_t p = 0; p < rb.size(); ++p) {
    const Block& bp = blocks_[rb[p]];
    if (bp.variable < 0) continue;
    AddGradient(jp, r, w.b.data() + bp.offset, m, bp.tangent);
    if (!assemble_h) {
      jp += m * bp.tangent;
      continue;
    }
    AddDiagonal(jp, m, bp.tangent, w.diagonal_sum.data() + w.diagonal_sum_start[bp.variable],
                buffer);
    const double* jq = jp + m * bp.tangent;
    for (size_t q = p + 1; q < rb.size(); ++q) {
      const Block& bq = blocks_[rb[q]];
      if (bq.variable < 0) continue;
      const double* this_q = jq;
      jq += m * bq.tangent;
      if (bq.variable == bp.variable) continue;
      const uint32_t place = w.pair_place[pair++];
      // H(row, col) with the row block first in H's order.
      const bool swap = bp.variable > bq.variable;
      const Block& row = swap ? bq : bp;
      const Block& col = swap ? bp : bq;
      Eigen::Map<Eigen::MatrixXd> acc(buffer, ld, ld);
      acc.topLeftCorner(row.tangent, col.tangent).setZero();
      AddOuter(swap ? this_q : jp, swap ? jp : this_q, buffer, ld, m, row.tangent, col.tangent);
      const bool opens = place & Workspace::kOpens;
      const int start = static_cast<int>(place & ~Workspace::kOpens);
      for (int j = 0; j < col.tangent; ++j) {
        const int first = w.col_start[start + j];
        for (int i = 0; i < row.tangent; ++i) {
          double& dst = w.H(first + i);
          dst = opens ? acc(i, j) : dst + acc(i, j);
        }
      }
    }
    jp += m * bp.tangent;
  }
}

// The diagonal blocks' sums into H, and the undamped diagonal.
void GaussNewtonProblem::WriteDiagonalBlocks() {
  Workspace& w = *ws_;
  pool_->ParallelFor(w.variables.size(), [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) {
      const Block& b = blocks_[w.variables[v]];
      const double* sum = w.diagonal_sum.data() + w.diagonal_sum_start[v];
      for (int j = 0; j < b.tangent; ++j) {
        const int last = w.diagonal[b.offset + j];  // H(j, j); the column's block ends there
        for (int i = 0; i <= j; ++i, ++sum)
          w.H(last - j + i) = *sum;
        w.diagonal_saved[b.offset + j] = sum[-1];
      }
    }
  });
  w.SetDampingFloor(kRelativeDampingFloor);
}


double GaussNewtonProblem::Linearize(bool assemble_h) {
  const double chi2 = Evaluate();
  Workspace& w = *ws_;
  if (assemble_h && w.keep_jacobians) AssembleKept();
  return chi2;
}

double GaussNewtonProblem::Evaluate() {
  Workspace& w = *ws_;
  const std::vector<int>& variables = w.variables;
  const int nvar = static_cast<int>(variables.size());
  pool_->ParallelFor(nvar, [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) {
      const Block& b = blocks_[variables[v]];
      if (w.plus_jac_off[v] >= 0) b.manifold->PlusJacobian(b.values, w.plus_jac.data() + w.plus_jac_off[v]);
    }
  });
  if (w.keep_jacobians) {
    EvaluateKept();
  } else {
    EvaluateInGroups();
  }
  double chi2 = 0;
  for (double c : w.chi2_terms) chi2 += c;
  return chi2;
}

// A worker thread's room for one residual: its values, ambient and local
// Jacobians, and a block of H; grown once, so no allocation once iterating.
struct GaussNewtonProblem::WorkerScratch {
  std::vector<double> r, ambient, local, buffer;
  static WorkerScratch& Of(const Workspace& w) {
    thread_local WorkerScratch s;
    auto grow = [](std::vector<double>& v, size_t n) {
      if (v.size() < n) v.resize(n);
    };
    grow(s.r, static_cast<size_t>(w.max_rows));
    grow(s.ambient, w.max_ambient);
    grow(s.local, w.max_local);
    grow(s.buffer, static_cast<size_t>(w.max_tangent) * w.max_tangent);
    return s;
  }
};

void GaussNewtonProblem::EvaluateKept() {
  Workspace& w = *ws_;
  pool_->ParallelFor(residuals_.size(), [&](size_t begin, size_t end) {
    WorkerScratch& s = WorkerScratch::Of(w);
    for (size_t k = begin; k < end; ++k)
      w.chi2_terms[k] =
          EvaluateResidual(k, w.r.data() + w.residual_offset[k], s.ambient.data(), s.local.data());
  });
  const int nvar = static_cast<int>(w.variables.size());
  pool_->ParallelFor(nvar, [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) {
      const Block& b = blocks_[w.variables[v]];
      Eigen::Map<Eigen::VectorXd> g(w.b.data() + b.offset, b.tangent);
      g.setZero();
      for (int t = w.gradient_start[v]; t < w.gradient_start[v + 1]; ++t) {
        const auto [k, p] = w.gradient_terms[t];
        AddGradient(w.jac_local.data() + w.jac_local_off[w.slot_start[k] + p],
                    w.r.data() + w.residual_offset[k], g.data(), residuals_[k].m, b.tangent);
      }
    }
  });
}

// A group's members share no variable: they add to b and H at once.
void GaussNewtonProblem::EvaluateInGroups() {
  Workspace& w = *ws_;
  std::fill(w.b.begin(), w.b.end(), 0.0);
  std::fill(w.diagonal_sum.begin(), w.diagonal_sum.end(), 0.0);
  const bool assemble_h = w.HasH();
  const size_t groups = w.group_start.size() - 1;
  double* run_chi2 = w.chi2_terms.data();
  for (size_t g = 0; g < groups; ++g) {
    const int* members = w.by_group.data() + w.group_start[g];
    const size_t size = w.group_start[g + 1] - w.group_start[g];
    const size_t runs = (size + kChi2Run - 1) / kChi2Run;
    pool_->ParallelFor(runs, [&](size_t begin, size_t end) {
      WorkerScratch& s = WorkerScratch::Of(w);
      for (size_t run = begin; run < end; ++run) {
        double sum = 0;
        for (size_t i = run * kChi2Run; i < std::min(size, (run + 1) * kChi2Run); ++i) {
          sum += EvaluateResidual(members[i], s.r.data(), s.ambient.data(), s.local.data());
          AddResidualTerms(members[i], s.r.data(), s.local.data(), assemble_h, s.buffer.data());
        }
        run_chi2[run] = sum;
      }
    }, 1);
    run_chi2 += runs;
  }
  if (assemble_h) WriteDiagonalBlocks();
}

// H from the kept Jacobians, block by block; each block is written by one
// thread only.
void GaussNewtonProblem::AssembleKept() {
  Workspace& w = *ws_;
  if (w.qr) return LoadJacobian();
  pool_->ParallelFor(w.kept_blocks.size(), [&](size_t begin, size_t end) {
    thread_local Eigen::MatrixXd buffer;
    if (buffer.rows() < w.max_tangent) buffer.resize(w.max_tangent, w.max_tangent);
    for (size_t t = begin; t < end; ++t) {
      const Workspace::KeptBlock& hb = w.kept_blocks[t];
      const int tr = blocks_[w.variables[hb.row_block]].tangent;
      const int tc = blocks_[w.variables[hb.col_block]].tangent;
      auto acc = buffer.topLeftCorner(tr, tc);
      acc.setZero();
      for (int k = hb.term_begin; k < hb.term_end; ++k) {
        const Workspace::Contribution& c = w.terms[k];
        AddOuter(w.jac_local.data() + c.jp, w.jac_local.data() + c.jq, buffer.data(),
                 static_cast<int>(buffer.rows()), c.m, tr, tc);
      }
      const bool diag = hb.row_block == hb.col_block;
      for (int j = 0; j < tc; ++j) {
        const int start = w.col_start[hb.start + j];
        const int height = diag ? j + 1 : tr;
        for (int i = 0; i < height; ++i)
          w.H(start + i) = acc(i, j);
      }
    }
  });
  for (int i = 0; i < w.n; ++i) w.diagonal_saved[i] = w.H(w.diagonal[i]);
  w.SetDampingFloor(kRelativeDampingFloor);
}

void GaussNewtonProblem::SolveNormalEquations(const double* g, double* x) {
  Workspace& w = *ws_;
  if (w.qr) {
    w.qr->SolveNormal(g, x);
  } else {
    w.cholesky->Solve(g, x);
  }
}

bool GaussNewtonProblem::SolveWithLastFactor(double* step_norm) {
  Workspace& w = *ws_;
  SolveNormalEquations(w.b.data(), w.dx.data());
  for (double& d : w.dx) d = -d;
  *step_norm = Eigen::Map<const Eigen::VectorXd>(w.dx.data(), w.n).norm();
  return std::isfinite(*step_norm);
}

bool GaussNewtonProblem::SolveStep(double lambda, double* step_norm) {
  Workspace& w = *ws_;
  if (w.qr) return SolveStepByQR(lambda, step_norm);
  for (int i = 0; i < w.n; ++i)
    w.H(w.diagonal[i]) = w.diagonal_saved[i] + lambda * std::max(w.diagonal_saved[i], w.damping_floor);
  if (!w.cholesky->Factorize()) return false;
  w.cholesky->Solve(w.b.data(), w.dx.data());
  for (double& d : w.dx) d = -d;
  *step_norm = Eigen::Map<const Eigen::VectorXd>(w.dx.data(), w.n).norm();
  return std::isfinite(*step_norm);
}

// min |J dx + r|^2 + lambda |D dx|^2 as one least-squares problem in A.
bool GaussNewtonProblem::SolveStepByQR(double lambda, double* step_norm) {
  Workspace& w = *ws_;
  double* a = w.qr->values();
  for (int c = 0; c < w.n; ++c)
    a[w.qr_col_ptr[c + 1] - 1] = std::sqrt(lambda * std::max(w.diagonal_saved[c], w.damping_floor));
  if (!w.qr->Factorize()) return false;
  w.qr->SolveLeastSquares(w.qr_rhs.data(), w.dx.data());
  *step_norm = Eigen::Map<const Eigen::VectorXd>(w.dx.data(), w.n).norm();
  return std::isfinite(*step_norm);
}

double GaussNewtonProblem::PredictedDecrease(double lambda) const {
  // With (H + lambda D) dx = -b, the model |r + J dx|^2 falls by
  // -2 b.dx - dx'H dx = -b.dx + lambda dx'D dx.
  const Workspace& w = *ws_;
  double decrease = 0;
  for (int i = 0; i < w.n; ++i)
    decrease += -w.b[i] * w.dx[i] + lambda * std::max(w.diagonal_saved[i], w.damping_floor) * w.dx[i] * w.dx[i];
  return decrease;
}

void GaussNewtonProblem::SaveEstimate() {
  Workspace& w = *ws_;
  size_t o = 0;
  for (int v : w.variables) {
    std::copy(blocks_[v].values, blocks_[v].values + blocks_[v].size, w.x_saved.begin() + o);
    o += blocks_[v].size;
  }
}

void GaussNewtonProblem::RestoreEstimate() {
  Workspace& w = *ws_;
  size_t o = 0;
  for (int v : w.variables) {
    std::copy(w.x_saved.begin() + o, w.x_saved.begin() + o + blocks_[v].size, blocks_[v].values);
    o += blocks_[v].size;
  }
}

void GaussNewtonProblem::ApplyStep() {
  Workspace& w = *ws_;
  pool_->ParallelFor(w.variables.size(), [&](size_t begin, size_t end) {
    thread_local std::vector<double> tmp;
    if (tmp.size() < static_cast<size_t>(w.max_size)) tmp.resize(w.max_size);
    for (size_t v = begin; v < end; ++v) {
      Block& b = blocks_[w.variables[v]];
      const double* d = w.dx.data() + b.offset;
      if (b.manifold) {
        b.manifold->Plus(b.values, d, tmp.data());
        std::copy(tmp.begin(), tmp.begin() + b.size, b.values);
      } else {
        for (int k = 0; k < b.size; ++k) b.values[k] += d[k];
      }
    }
  });
}

// One Solve's progress: the estimate's chi2, the trust region, what the
// workspace holds, and the result so far.
struct GaussNewtonProblem::SolveState {
  SolveState(const GaussNewtonOptions& o, std::chrono::steady_clock::time_point start)
      : options(o), t0(start), damping(o.damping) {}

  const GaussNewtonOptions& options;
  const std::chrono::steady_clock::time_point t0;
  SolveResult result;
  CholeskyKind linear_solver = CholeskyKind::kAuto;
  double chi2 = 0;
  // The last evaluation (b; J or H) is at the estimate.
  bool jacobians_current = true;
  // Pure Gauss-Newton until a step fails; from then on Levenberg-Marquardt
  // with Ceres's trust-region schedule (its radius is 1/lambda), so that
  // on a problem with several minima both paths walk the same way.
  bool pure_gauss_newton = true;
  double damping, decrease_factor = 2;
  double last_decrease = 1.0;
  bool have_factor = false;  // the last factorisation is of a full step's H
  bool done = false;         // Finish was called

  void Record(int iteration, double step_norm, bool accepted, double solve_s) {
    IterationRecord it;
    it.iteration = iteration;
    it.chi2 = chi2;
    it.step_norm = step_norm;
    it.time_s = Seconds(t0);
    it.accepted = accepted;
    it.linear_solver_time_s = solve_s;
    result.trace.push_back(it);
    if (options.verbose) std::fprintf(stderr, "%s\n", FormatIteration(it).c_str());
  }
  void Finish(const char* termination, const std::string& message, bool converged) {
    result.termination = termination;
    result.message = message + " (linear solver " + ToString(linear_solver) + ")";
    result.converged = converged;
    result.final_chi2 = chi2;
    result.usable = IsUsableEstimate(result.initial_chi2, chi2);
    result.time_s = Seconds(t0);
    done = true;
  }
  void FinishFunctionTolerance(double decrease) {
    Finish("convergence", "function tolerance reached: relative decrease " + std::to_string(decrease),
           true);
  }
  void FinishAtRounding() {
    Finish("convergence", "converged: the next step changes chi-squared only within rounding", true);
  }
};

// A full step (pure or damped) from the current estimate, as DampedStep
// leaves it.
struct GaussNewtonProblem::TrialStep {
  double solve_s = 0, new_chi2 = 0, step_norm = 0, rho = 1;
  bool accepted = false, at_rounding = false;
};

SolveResult GaussNewtonProblem::Solve(const GaussNewtonOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto t0 = std::chrono::steady_clock::now();
  SerialLinearAlgebraScope serial;  // the factorisations' libraries on this thread alone
  SolveState s(options, t0);
  SolveResult& result = s.result;
  result.solver = "gn";
  Prepare(options);
  Workspace& w = *ws_;
  s.linear_solver = w.linear_solver;
  result.linear_solver = ToString(w.linear_solver);
  if ((w.linear_solver == CholeskyKind::kSupernodalOrSimplicial ||
       w.linear_solver == CholeskyKind::kTwoHalves) && w.cholesky)
    result.linear_solver += ": " + w.cholesky->Method();

  result.setup_time_s = Seconds(t0);
  // Every candidate is evaluated with its gradient (and H, unless the
  // Jacobians are kept for it): accepted (the common case) it needs no
  // evaluation of its own next iteration.
  s.chi2 = Evaluate();
  s.jacobians_current = true;
  result.linearize_time_s += Seconds(t0) - result.setup_time_s;
  result.initial_chi2 = s.chi2;
  s.Record(0, 0, true, 0);
  if (!std::isfinite(s.chi2)) {
    s.Finish("failure", "the initial estimate gives a non-finite chi-squared", false);
    return result;
  }
  if (w.n == 0) {
    s.Finish("convergence", "nothing to optimise: every block is constant", true);
    return result;
  }

  for (int iter = 1; iter <= options.max_iterations && !s.done; ++iter) {
    if (options.reuse_factorization && s.have_factor && s.last_decrease < kChordThreshold &&
        ChordStep(s, iter))
      continue;
    FullStep(s, iter);
  }
  if (!s.done)
    s.Finish("no_convergence",
             "iteration limit reached (" + std::to_string(options.max_iterations) + ")", false);
  // Conjugate gradients choose their preconditioner at the first factorisation.
  if (w.linear_solver == CholeskyKind::kConjugateGradients && w.cholesky)
    result.linear_solver = std::string(ToString(w.linear_solver)) + ": " + w.cholesky->Method();
  return result;
}

// Near the optimum H hardly changes: a step with the last factorisation (a
// chord step) costs a linearisation and two triangular solves instead of a
// factorisation. Kept only if it lowers chi2. Returns whether the iteration
// is over (the step was kept); else a full step follows from the same point.
// A chord step never ends the solve: with an H from an earlier estimate its
// decrease says how good that H still is, not how far the optimum is (on
// manhattan two chord steps of under 1e-10 each stopped 2e-6 above it). A
// small or refused one hands over to a full step, whose own decrease decides.
bool GaussNewtonProblem::ChordStep(SolveState& s, int iter) {
  SolveResult& result = s.result;
  const auto tl = std::chrono::steady_clock::now();
  if (!s.jacobians_current) Evaluate();
  result.linearize_time_s += Seconds(tl);
  SaveEstimate();
  double step_norm = 0;
  const auto ts = std::chrono::steady_clock::now();
  const bool ok = SolveWithLastFactor(&step_norm);
  const double solve_s = Seconds(ts);
  result.linear_solver_time_s += solve_s;
  s.have_factor = false;
  if (!ok) return false;
  ApplyStep();
  const auto te = std::chrono::steady_clock::now();
  const double new_chi2 = Evaluate();
  result.linearize_time_s += Seconds(te);
  s.jacobians_current = true;
  if (!(std::isfinite(new_chi2) && new_chi2 <= s.chi2)) {
    RestoreEstimate();
    s.jacobians_current = false;
    return false;
  }
  const double decrease = (s.chi2 - new_chi2) / std::max(s.chi2, std::numeric_limits<double>::min());
  s.chi2 = new_chi2;
  result.iterations = iter;
  ++result.reused_factorizations;
  s.Record(iter, step_norm, true, solve_s);
  // Chord steps go on while each still does a useful share of the work and
  // the decreases still shrink fast. A chord that no longer halves the last
  // decrease converges linearly at a poor rate where a full step would not:
  // far from a minimum, under damping (GNC's weighted solves: 100 chord steps
  // of 0.02% each). Near one the decreases shrink by orders of magnitude
  // (the shared files' iterations are the same with and without the test).
  s.have_factor = decrease >= s.options.function_tolerance &&
                  decrease <= kChordContraction * s.last_decrease;
  s.last_decrease = decrease;
  return true;
}

// Linearisation at the estimate (J and b are there already after an
// accepted step), the gradient test, then a step and its acceptance.
void GaussNewtonProblem::FullStep(SolveState& s, int iter) {
  Workspace& w = *ws_;
  const auto tl = std::chrono::steady_clock::now();
  if (!s.jacobians_current) {
    Linearize();
  } else if (w.keep_jacobians) {
    AssembleKept();
  }
  s.jacobians_current = false;
  s.result.linearize_time_s += Seconds(tl);
  const double g_max = MaxAbs(w.b, w.n);
  // Relative to chi2 per residual, as on the Ceres path, so that scaling
  // every information matrix leaves the iterations as they are.
  const double per_residual = s.chi2 / std::max(1, w.residual_rows);
  if (g_max <= s.options.gradient_tolerance * per_residual) {
    char text[112];
    std::snprintf(text, sizeof text,
                  "gradient tolerance reached: max |g| %.3g, %.3g times chi2 per residual", g_max,
                  per_residual > 0 ? g_max / per_residual : 0.0);
    s.Finish("convergence", text, true);
    return;
  }
  SaveEstimate();
  double x_norm = 0;
  for (double v : w.x_saved) x_norm += v * v;
  x_norm = std::sqrt(x_norm);
  const TrialStep t = DampedStep(s);
  s.result.iterations = iter;
  AcceptStep(s, iter, t, x_norm);
}

// Steps from the saved estimate, damped more each time one fails, until one
// lowers chi2 by enough of what its model predicted, one changes it only
// within rounding, or the damping runs out.
GaussNewtonProblem::TrialStep GaussNewtonProblem::DampedStep(SolveState& s) {
  Workspace& w = *ws_;
  TrialStep t;
  t.new_chi2 = s.chi2;
  for (;;) {
    const double lambda = s.pure_gauss_newton ? 0.0 : s.damping;
    const auto ts = std::chrono::steady_clock::now();
    bool ok = SolveStep(lambda, &t.step_norm);
    const double seconds = Seconds(ts);
    t.solve_s += seconds;
    s.result.linear_solver_time_s += seconds;
    if (ok) {
      const double predicted = PredictedDecrease(lambda);
      ApplyStep();
      // The gradient at this point is needed again if the step is refused.
      if (w.keep_jacobians) w.b_saved.assign(w.b.begin(), w.b.end());
      const auto te = std::chrono::steady_clock::now();
      t.new_chi2 = Evaluate();
      s.result.linearize_time_s += Seconds(te);
      t.rho = predicted > 0 ? (s.chi2 - t.new_chi2) / predicted : -1;
      if (std::isfinite(t.new_chi2) && t.new_chi2 <= s.chi2 && t.rho > kMinRelativeDecrease) {
        t.accepted = true;
        return t;
      }
      RestoreEstimate();
      // A change within rounding of chi2 means the estimate is already at
      // the minimum: damping would only repeat the same factorisation.
      if (std::isfinite(t.new_chi2) && std::abs(t.new_chi2 - s.chi2) <= 1e-12 * s.chi2) {
        t.at_rounding = true;
        return t;
      }
      if (w.keep_jacobians) {
        w.b.swap(w.b_saved);  // H is still the estimate's
      } else {
        // The candidate's b and H replaced the estimate's: linearised again
        // (a refusal costs an evaluation, keeping both every step's memory).
        const auto tr = std::chrono::steady_clock::now();
        Linearize();
        s.result.linearize_time_s += Seconds(tr);
      }
    }
    s.damping *= s.decrease_factor;
    s.decrease_factor *= 2;
    if (s.options.verbose)
      std::fprintf(stderr, "         %s step %s; trying a damped step (lambda %.1e)\n",
                   s.pure_gauss_newton ? "Gauss-Newton" : "damped",
                   !ok ? "met normal equations that are not positive definite"
                   : !(t.new_chi2 <= s.chi2) ? "raised chi2"
                                             : "lowered chi2 by under 0.1% of what its model predicted",
                   s.damping);
    s.pure_gauss_newton = false;
    if (s.damping > kMaxDamping) return t;
  }
}

// The trust region's update, the estimate's, and the convergence tests.
void GaussNewtonProblem::AcceptStep(SolveState& s, int iter, const TrialStep& t, double x_norm) {
  s.jacobians_current = t.accepted;  // else the workspace holds the refused candidate's
  if (t.accepted) {
    // Ceres's rule: a step that did what the model said widens the trust
    // region (up to 3 times), a poor one narrows it.
    s.damping = std::max(kMinDamping,
                         s.damping * std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * t.rho - 1.0, 3)));
    s.decrease_factor = 2;
  }
  if (t.at_rounding) {
    s.Record(iter, t.step_norm, false, t.solve_s);
    s.FinishAtRounding();
    return;
  }
  if (!t.accepted) {
    s.Record(iter, t.step_norm, false, t.solve_s);
    s.Finish("convergence",
             "no step lowers chi-squared, damped or not: the estimate is a minimum "
             "to the solver's precision",
             true);
    return;
  }
  const double decrease = (s.chi2 - t.new_chi2) / std::max(s.chi2, std::numeric_limits<double>::min());
  s.chi2 = t.new_chi2;
  s.last_decrease = decrease;
  s.have_factor = true;
  s.Record(iter, t.step_norm, true, t.solve_s);
  if (decrease < s.options.function_tolerance)
    s.FinishFunctionTolerance(decrease);
  else if (t.step_norm <= s.options.parameter_tolerance * (x_norm + s.options.parameter_tolerance))
    s.Finish("convergence", "parameter tolerance reached", true);
}

}  // namespace cairn
