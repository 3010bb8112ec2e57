// The Gauss-Newton path's partial updates behind IncrementalOptimizer::Update,
// in the manner of iSAM2 (Kaess et al. 2012) on a sparse Cholesky factor
// instead of a Bayes tree. The normal equations are kept at fixed
// linearisation points, the gradient as one more (last) row and column, so
// that the factor's last row is the forward solve: a new edge adds its
// rank-d term J^T J (with J^T r in that row) as an update of the factor; an
// edge whose pose moved past the relinearisation threshold has its old term
// downdated and the new one updated; a new pose takes a reserved column at
// the end of the elimination order. Only the columns on the modified paths of
// the elimination tree are solved again, and from them only the subtrees
// whose steps change by more than the wildfire threshold. A fresh ordering
// (AMD, new poses last) and factorisation are made when the reserved columns
// run out, when the fill has grown past a bound, or when the gauge may move.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>

#include <memory>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

class UpdatableCholesky;  // backend/linear, internal

// The approximations and bounds of partial updates.
struct PartialUpdateOptions {
  // A pose whose step from its linearisation point exceeds this (largest
  // tangent component: m, rad) has its edges re-linearised at the next
  // Update, as iSAM2's relinearizeThreshold. 0 re-linearises every pose that moved.
  double relinearize_threshold = 0.1;
  // How much factor work (entries of L that the re-linearised edges'
  // downdates and updates pass) one Update may spend re-linearising; the
  // farthest-moved poses that fit go first, the rest wait for the next
  // Updates, and a pose whose own work is over it for the next fresh
  // factorisation. Re-linearising was most of a step's work: 2e6 made the
  // median step about twice as dear as 5e5 on 2D graphs of 10,000 poses,
  // for no better estimate (docs/benchmarks.md).
  long relinearize_budget = 500000;
  // Solving again stops in a subtree of the elimination tree where the
  // step changed by no more than this (iSAM2's wildfire threshold); 0
  // solves every unknown the change reaches.
  double wildfire_threshold = 1e-3;
  // Poses the factor has room for beyond those it holds (at least this
  // many, and a twentieth of those it holds); a fresh ordering and
  // factorisation when they are used up.
  int reserve_poses = 500;
  // Entries the factor may gain (fill from loop closures through the
  // appended poses) before a fresh ordering and factorisation: fill_bound,
  // or fill_fraction of the factor as it was built when that is more (a
  // fresh factorisation costs what the graph holds, so on a graph ten
  // times larger it comes ten times less often).
  long fill_bound = 200000;
  double fill_fraction = 0.1;

  // The thresholds, fill_bound and fill_fraction are numbers >= 0, reserve_poses and
  // relinearize_budget >= 1.
  bool IsValid(std::string* error) const;
};

// A partial update's estimate is refused when it raises the cost of the
// edges it moves by more than this factor: IncrementalOptimizer::Update then
// steps once from a fresh linearisation, and solves the graph whole if that
// is refused too. Small rises are the kept linearisation's normal lag (on
// city10000 a third of the updates raise it by up to 10%); MIT's long loops
// raised it tenfold and more, and the estimate diverged (chi2 2.8e11).
constexpr double kAcceptedCostGrowth = 3.0;
// A refused step is first taken again from a fresh linearisation of the
// poses it moved, when re-linearising them passes at most this many factor
// entries per entry of the factor (an update or downdate column passes its
// path in the elimination tree; a fresh factorisation costs far more than
// one pass over the factor).
constexpr double kRetryCostPerFactorEntry = 2.0;
// How many of the farthest-moved poses one Update weighs for
// re-linearisation (each costs a walk up its path to find its price).
constexpr int kRelinearizeCandidates = 64;

// Why an Update ordered and factorised afresh: the first update (or one
// after a whole solve moved the estimate), the reserved columns used up,
// the fill past its bound, the gauge that may move, or a partial step that
// was refused (its cost rose, or the factor stopped being positive definite).
enum class RebuildReason { kNone, kStart, kRoom, kFill, kGauge, kRefused };
inline constexpr size_t kRebuildReasons = 6;  // RebuildReason's values
const char* ToString(RebuildReason reason);

// What one Update did, for benchmarks and tests.
struct UpdateResult {
  double time_s = 0;
  bool refactorized = false;  // a fresh ordering and factorisation
  RebuildReason reason = RebuildReason::kNone;  // why, when refactorized
  bool exact = false;         // fell back to a full Optimize (graphs partial updates do not cover)
  int new_edges = 0;
  int relinearized_vertices = 0;  // whose edges were re-linearised
  int solved_unknowns = 0;        // scalar unknowns solved again
  int retried = 0;  // refused steps taken again after re-linearising the poses they moved
  long factor_nonzeros = 0;
};

class PartialUpdater {
 public:
  // `manifold` is the pose manifold, `loop_loss` the loss on loop closures
  // (may be null): both outlive this, as does the graph.
  PartialUpdater(PoseGraph* graph, const ceres::Manifold* manifold,
                 const ceres::LossFunction* loop_loss, const PartialUpdateOptions& options);
  ~PartialUpdater();
  PartialUpdater(const PartialUpdater&) = delete;
  PartialUpdater& operator=(const PartialUpdater&) = delete;

  // Whether partial updates cover this graph: poses only, a gauge of whole
  // held poses.
  static bool Covers(const PoseGraph& graph);
  // Takes in the edges added since the last call and moves the estimate
  // (the graph's vertices) to the new solution of the kept linear system.
  // False when the graph is not covered or the factor is not positive
  // definite: the caller then solves it whole.
  bool Update(UpdateResult* out);
  // The estimate was moved by someone else (a full solve): the next Update
  // linearises everything afresh there.
  void Invalidate() {
    if (valid_) reason_ = RebuildReason::kStart;  // a refusal keeps its own reason
    valid_ = false;
  }

 private:
  struct Columns;
  // The augmented normal matrix's pattern: H's block columns (the row
  // blocks above each diagonal block), and its scalar compressed columns.
  struct NormalPattern {
    std::vector<int> block_start, block_rows, col_ptr, rows;
  };
  bool Rebuild(UpdateResult* out);
  void PlaceVariables(const std::vector<bool>& held);
  bool AssembleAndFactorize();
  NormalPattern PlanNormalPattern() const;
  void AddEdgeTerms(size_t e, const NormalPattern& pattern, std::vector<double>* values) const;
  void ResetTree();
  void ComputeComponents();
  bool TakeInGauge(const Edge& e);
  int Find(int v);
  void NormalizeRotation(Vertex& v) const;
  void Linearize(size_t e);
  void AppendColumns(size_t e, Columns* c) const;
  void AddEdgeToState(size_t e);
  long PathEntries(int j) const;
  std::vector<int> ChooseRelinearization();
  void CollectRelinearization(Columns* up, Columns* down, UpdateResult* out);
  void Relinearize(const std::vector<int>& chosen, Columns* up, Columns* down);
  void TakeInNewEdges(Columns* up, Columns* down, UpdateResult* out);
  bool Modify(UpdateResult* out);
  bool ModifyAndSolve(const Columns& up, const Columns& down, UpdateResult* out);
  void MarkPath(int j);
  void Reparent(int j, int p);
  void BackSubstitute(UpdateResult* out);
  double ChangedCost();
  bool WriteEstimates();
  const double* LinPoint(size_t vertex) const { return &x0_[vertex * p_]; }

  PoseGraph* graph_;
  const ceres::Manifold* manifold_;
  const ceres::LossFunction* loop_loss_;
  double relinearize_threshold_, wildfire_threshold_;
  int reserve_;
  long fill_bound_, relinearize_budget_;
  double fill_fraction_;
  int d_, p_, stride_;
  bool valid_ = false;
  bool rebuild_ = true;
  RebuildReason reason_ = RebuildReason::kStart;  // of the next rebuild

  std::unique_ptr<UpdatableCholesky> factor_;
  int n_ = 0, rhs_ = 0;      // unknowns (reserved included); the gradient's row
  int used_ = 0, cap_ = 0;   // variable blocks placed; blocks the factor has room for
  long nnz_at_build_ = 0;
  int updates_since_build_ = 0;
  size_t edges_in_ = 0;

  // Per vertex (graph index): its block in the order (-1: none, e.g. held),
  // its linearisation point, its edges; union-find for the gauge.
  std::vector<int> slot_;
  std::vector<double> x0_;
  std::vector<std::vector<int>> edges_of_;
  std::vector<bool> touched_;
  std::vector<int> uf_, min_id_;
  std::vector<char> anchored_;
  // Per block: its vertex. Per scalar: the step from the linearisation point.
  std::vector<int> vertex_at_;
  std::vector<double> delta_;
  // Per edge: its cost function and its whitened Jacobian and residual at
  // the linearisation points (d x 2d row-major, then d).
  std::vector<std::unique_ptr<ceres::CostFunction>> cost_;
  std::vector<double> jr_;
  // The elimination tree, kept as the factor's pattern changes.
  std::vector<int> parent_;
  std::vector<std::vector<int>> children_;
  // Per-update scratch.
  std::vector<int> stamp_, marked_, relinearize_, changed_blocks_;
  std::vector<int> block_stamp_, done_, edge_stamp_;
  std::vector<char> waiting_;  // per vertex: in relinearize_
  // The acceptance test of a new estimate: per edge, the round it was last
  // counted in; the changed vertices' estimates before it.
  std::vector<int> cost_stamp_;
  int cost_round_ = 0;
  std::vector<PoseParams> saved_;
  int round_ = 0;
};

}  // namespace cairn
