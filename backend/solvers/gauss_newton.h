// cairn's own Gauss-Newton solver. It takes the same Ceres cost functions,
// loss functions and manifolds a ceres::Problem takes (so its Jacobians come
// from the very same autodiff factors) and solves the normal equations
// H dx = -b by sparse Cholesky (or sparse QR of J, or conjugate gradients:
// linear_solver.h), with the symbolic analysis done once.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>

#include <Eigen/Core>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "cairn/solvers/solve_result.h"
#include "cairn/solvers/linear_solver.h"

namespace cairn {

class ThreadPool;  // backend/linear, internal

// The common options (iterations, tolerances, threads, progress, robust
// loss for loop closures) mean the same as for the Ceres path.
struct GaussNewtonOptions : SolverOptions {
  GaussNewtonOptions() = default;
  // The shared settings taken from `common`, the Gauss-Newton ones at their
  // defaults.
  explicit GaussNewtonOptions(const SolverOptions& common) : SolverOptions(common) {}

  // Levenberg-Marquardt damping (times diag(H)) that the fallback starts
  // from once a pure Gauss-Newton step fails; it then follows Ceres's
  // trust-region schedule, whose radius is 1/damping (Ceres starts ours at
  // 1e10), so both paths take the same steps on hard problems.
  double damping = 1e-10;
  CholeskyKind linear_solver = CholeskyKind::kAuto;
  // Once chi2 falls by less than 2% a step, try the last factorisation of
  // H with the new gradient before factorising again (see Solve).
  bool reuse_factorization = true;
  // Local Jacobians up to this size are kept from the evaluation to H's
  // assembly, which then gathers b and H part by part. Without them each
  // residual adds its terms as it is evaluated, in groups that share no
  // variable; each group's pass over the whole graph misses the cache, so
  // the linearisation takes longer (parking-garage: 1.3 times on one
  // thread, 2 times on two). Beyond this size (about 450,000 2D or 115,000
  // 3D edges) the memory counts for more: the Jacobians of a million 2D
  // poses are 225 MB.
  size_t max_kept_jacobian_bytes = size_t{64} << 20;
  // The most the two-halves factorisation's numeric factors may hold in
  // memory, in bytes; beyond, one half's is kept on disk while the other
  // works (one core, same result). Negative: about 1.5 KB an edge, at least
  // 256 MiB (domain_cholesky.h); infinity: always in memory.
  double factor_memory_bytes = -1;

  // SolverOptions::IsValid, and a damping that is a number >= 0.
  bool IsValid(std::string* error) const;
};

// Residuals evaluated from data the caller holds (a pose graph's edges)
// rather than one ceres::CostFunction object each: at a million edges those
// objects were 250 MB. Member k is evaluated as CostFunction::Evaluate.
class ResidualFamily {
 public:
  virtual ~ResidualFamily() = default;
  virtual int NumResiduals(size_t member) const = 0;
  virtual bool Evaluate(size_t member, const double* const* parameters, double* residuals,
                        double** jacobians) const = 0;
};

// A least-squares problem in the shape of ceres::Problem, for our solver.
class GaussNewtonProblem {
 public:
  GaussNewtonProblem();
  ~GaussNewtonProblem();

  // `values` (size doubles) stays owned by the caller and is updated in
  // place; `manifold` (not owned, may be null) sets the tangent space.
  void AddParameterBlock(double* values, int size, const ceres::Manifold* manifold = nullptr);
  void SetParameterBlockConstant(double* values);
  // Takes ownership of `cost` and `loss` (loss may be null). Blocks not yet
  // added are added without a manifold.
  void AddResidualBlock(ceres::CostFunction* cost, ceres::LossFunction* loss,
                        const std::vector<double*>& blocks);
  // A member of `family` (not owned; it must outlive the problem), its
  // blocks of the given sizes.
  void AddResidualBlock(const ResidualFamily* family, size_t member, ceres::LossFunction* loss,
                        const std::vector<double*>& blocks, const std::vector<int>& block_sizes);

  // Room for this many blocks and residuals, allocated once (optional: the
  // growth's slack is tens of megabytes on a graph of a million poses).
  void Reserve(size_t blocks, size_t residuals);

  int NumParameterBlocks() const;
  int NumResidualBlocks() const;

  // Sum over residual blocks of rho(|r|^2) (|r|^2 without a loss): with
  // whitened residuals, g2o's chi-squared.
  double Chi2();
  SolveResult Solve(const GaussNewtonOptions& options);

  // The steps Solve takes, for benchmarks and callers that drive their own
  // loop. Prepare fixes the pattern of H and runs the symbolic analysis;
  // Linearize assembles H and b at the current estimate and returns chi2;
  // SolveStep factorises H + lambda diag(H) and solves for the step (false
  // if not positive definite); ApplyStep moves the estimate by it.
  void Prepare(const GaussNewtonOptions& options);
  double Linearize(bool assemble_h = true);
  bool SolveStep(double lambda, double* step_norm);
  // The step from the last factorisation and the current gradient.
  bool SolveWithLastFactor(double* step_norm);
  void ApplyStep();
  int TangentDimension() const;
  long FactorNonZeros() const;
  CholeskyKind LinearSolver() const;  // the one Prepare chose

  // Undoes SetParameterBlockConstant (the next Prepare sees the change).
  void SetParameterBlockVariable(double* values);

  // For a problem that only grew: the next Prepare eliminates the variable
  // blocks in this order (blocks not listed come last, in the order they
  // were added) instead of computing a fresh fill-reducing ordering.
  // Honoured by the SuiteSparse factorisations; Eigen orders by itself. When the old
  // variables are still the first ones and every new block of H lies in a
  // new column (each new residual touches a new block, or only pairs H
  // already had), Prepare goes further and extends the last analysis
  // instead of redoing it (SparseCholesky::Extend).
  void SetOrderingHint(std::vector<const double*> order);
  // Whether the last Prepare extended the analysis before it.
  bool LastAnalysisExtended() const { return last_analysis_extended_; }
  // The elimination order of the variable blocks after Prepare (empty when
  // the linear solver does not report it), to pass back as a hint.
  std::vector<const double*> Ordering() const;

  // Marginal covariances, in the tangent space, of the given blocks at the
  // current estimate: H is linearised and factorised undamped and H X = E
  // solved for the blocks' columns (the Laplace approximation, as Ceres's
  // Covariance). A constant block gets a zero matrix. Needs Prepare; false
  // when H is not positive definite (an unobserved direction).
  bool MarginalCovariances(const std::vector<const double*>& blocks,
                           std::vector<Eigen::MatrixXd>* covariances);

 private:
  struct Block;
  struct Residual;
  struct Source;
  struct Workspace;
  struct HBlock;
  struct WorkerScratch;
  struct PreviousAnalysis;
  struct SolveState;
  struct TrialStep;

  // Prepare's stages, in order: number the variables, lay out the residuals'
  // storage, plan who adds to b (with the Jacobians kept) or group the
  // residuals, plan which block of H each pair of a residual's variables
  // adds to, lay out H's scalar pattern, then the symbolic analysis.
  void AddResidual(Residual r, std::unique_ptr<ceres::LossFunction> loss,
                   const std::vector<double*>& blocks, const std::vector<int>& sizes);
  bool EvaluateOf(const Residual& r, const double* const* params, double* out,
                  double** jacobians) const;
  const ceres::LossFunction* LossOf(const Residual& r) const;
  // A residual's blocks (indices into blocks_).
  struct BlockList {
    const int* first;
    size_t count;
    size_t size() const { return count; }
    int operator[](size_t p) const { return first[p]; }
    const int* begin() const { return first; }
    const int* end() const { return first + count; }
  };
  BlockList BlocksOf(const Residual& r) const;
  void NumberVariables();
  size_t LocalJacobianDoubles() const;
  void AllocateResiduals(bool keep_jacobians);
  template <typename F>
  void ForEachSlot(F&& f) const;
  template <typename F>
  void ForEachPairOf(size_t k, F&& f) const;
  template <typename F>
  void ForEachPair(F&& f) const;
  // Who adds to b, with the Jacobians kept; else the groups.
  void PlanGradient();
  void GroupResiduals();
  std::vector<int> PlanNormalMatrix(std::vector<HBlock>* h_blocks, std::vector<int>* pair_block);
  void PlanPattern(const std::vector<int>& col_blocks, std::vector<HBlock>* h_blocks,
                   std::vector<int>* col_ptr, std::vector<int>* rows);
  // With the Jacobians kept, each block's terms; else each pair's place.
  void PlanKeptTerms(const std::vector<HBlock>& h_blocks, const std::vector<int>& pair_block);
  void PlacePairs(const std::vector<HBlock>& h_blocks, const std::vector<int>& pair_block);
  void AnalyzePattern(PreviousAnalysis* previous, const std::vector<int>& col_ptr,
                      const std::vector<int>& rows);
  // CholeskyKind::kQR instead of the last four: the Jacobian's pattern, and
  // its values (for each linearisation) with diag(J^T J).
  void PlanJacobian();
  void LoadJacobian();
  std::vector<int> HintedOrdering() const;

  // Solve's iteration: a chord step with the last factorisation when chi2
  // has almost stopped falling, else a full step, linearised afresh and
  // damped until it is accepted or the solve ends.
  bool ChordStep(SolveState& s, int iteration);
  void FullStep(SolveState& s, int iteration);
  TrialStep DampedStep(SolveState& s);
  void AcceptStep(SolveState& s, int iteration, const TrialStep& t, double x_norm);

  // chi2 at the estimate, with b and, unless the Jacobians are kept, H.
  double Evaluate();
  void EvaluateKept();
  void EvaluateInGroups();
  void AssembleKept();
  // Residual k at the estimate: its values into r, and its chi2 term; with
  // `local`, the local Jacobians of its variable slots there, one after
  // another (m x tangent, row-major), both scaled by the loss's sqrt(rho').
  // `ambient`: scratch.
  double EvaluateResidual(size_t k, double* r, double* ambient, double* local);
  // b and (assemble_h) H gain residual k's terms.
  void AddResidualTerms(size_t k, const double* r, const double* local, bool assemble_h,
                        double* buffer);
  void WriteDiagonalBlocks();
  bool SolveStepByQR(double lambda, double* step_norm);
  // x = H^-1 g with the last factorisation (kQR: R^T R x = g).
  void SolveNormalEquations(const double* g, double* x);
  // Fall of chi2 that the linear model promises for the step just solved.
  double PredictedDecrease(double lambda) const;
  void SaveEstimate();
  void RestoreEstimate();

  std::vector<Block> blocks_;
  std::unordered_map<const double*, int> block_index_;
  std::vector<Residual> residuals_;
  std::vector<Source> sources_;
  std::vector<std::unique_ptr<ceres::LossFunction>> losses_;
  std::vector<int> residual_blocks_;  // each residual's blocks, one after another
  std::unique_ptr<Workspace> ws_;
  std::unique_ptr<ThreadPool> pool_;
  std::vector<const double*> ordering_hint_;
  bool last_analysis_extended_ = false;
};

}  // namespace cairn
