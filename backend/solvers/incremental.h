// Incremental use as a robot runs: poses, odometry, loop closures, priors
// and point landmarks with their observations are added one at a time and the graph is optimised when asked, warm-started
// from the last solution. Both solvers keep their problem between calls and
// take in only what was added: Ceres's problem gains the new parameter and
// residual blocks; the Gauss-Newton problem keeps its cost functions and its
// fill-reducing ordering, with new poses appended at the end of it. Update()
// is the per-pose call: partial updates of a kept factor (iSAM2's scheme),
// at a cost set by what the new edges move rather than by the graph's size.
#pragma once

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/gauss_newton.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/incremental_partial.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {

struct IncrementalOptions {
  // Each solver's own options, its robust loss on loop closures included:
  // each problem is built with its solver's loss (both none by default).
  CeresOptions ceres;
  GaussNewtonOptions gauss_newton;
  // Gauss-Newton: appending new poses to an old ordering slowly costs fill;
  // a fresh ordering (AMD, or METIS and CAMD for two halves) is computed
  // once the variables have grown by this fraction since the last one (and
  // whenever the held vertices change).
  double reorder_growth = 0.1;

  // Update()'s thresholds and bounds (incremental_partial.h).
  PartialUpdateOptions partial;

  // Both solvers' options and `partial` are valid and reorder_growth is
  // >= 0; the optimizer's constructor throws std::invalid_argument otherwise.
  bool IsValid(std::string* error) const;
};

// A pose graph that grows and is re-optimised in place. The vertices' arrays
// are the estimate both solvers update, so each starts where the last
// optimisation (of either solver) stopped. Not copyable: the solvers hold
// pointers into the graph.
class IncrementalOptimizer {
 public:
  explicit IncrementalOptimizer(int dimension = 2, IncrementalOptions options = {});
  // Starts from an existing graph (copied), e.g. one read from a file.
  explicit IncrementalOptimizer(const PoseGraph& graph, IncrementalOptions options = {});
  ~IncrementalOptimizer();
  IncrementalOptimizer(const IncrementalOptimizer&) = delete;
  IncrementalOptimizer& operator=(const IncrementalOptimizer&) = delete;

  // `x` is the initial estimate, e.g. the last pose composed with the
  // odometry. Throws std::invalid_argument on a duplicate id.
  void AddPose(int64_t id, const SE2& x, bool fixed = false);
  void AddPose(int64_t id, const SE3& x, bool fixed = false);
  // A point landmark at p (2D: p.z ignored); observed through AddEdge with
  // EdgeKind::kLandmark (3D: an offset from SetOffset).
  void AddLandmark(int64_t id, const Eigen::Vector3d& p, bool fixed = false);
  void SetOffset(int32_t id, const SE3& offset) { graph_.SetOffset(id, offset); }
  // Measurements of `to` seen from `from`, with their information matrix
  // (3x3 in 2D, 6x6 in 3D, in g2o's order). Throws std::invalid_argument as
  // PoseGraph::AddEdge does.
  void AddOdometry(int64_t from, int64_t to, const SE2& z, const Eigen::Matrix3d& information);
  void AddOdometry(int64_t from, int64_t to, const SE3& z, const Matrix6d& information);
  void AddLoopClosure(int64_t from, int64_t to, const SE2& z, const Eigen::Matrix3d& information);
  void AddLoopClosure(int64_t from, int64_t to, const SE3& z, const Matrix6d& information);
  // An absolute measurement of one pose; a graph with a prior needs no gauge.
  void AddPrior(int64_t id, const SE2& z, const Eigen::Matrix3d& information);
  void AddPrior(int64_t id, const SE3& z, const Matrix6d& information);
  // The general form: any edge PoseGraph accepts.
  void AddEdge(const Edge& edge);

  // Optimises everything added so far from the current estimate. The gauge
  // is the batch solvers': FIX vertices, else a prior, else the lowest id.
  SolveResult Optimize(SolverKind solver = SolverKind::kGaussNewton);
  // What a robot calls after each new pose: takes in what was added since
  // the last call at the cost of what it changes, not of the graph's size
  // (PartialUpdater): new edges and edges whose poses moved past
  // partial.relinearize_threshold are (re-)linearised into the kept factor,
  // and the poses the change reaches get their new estimate. One Gauss-Newton
  // step on a kept linearisation, not a converged solve: Optimize() gives
  // the exact optimum when asked. Graphs with landmarks or a rotation-only
  // gauge are optimised whole (UpdateResult::exact).
  UpdateResult Update();

  // Marginal covariances (tangent space: 3x3 or 6x6, in the pose's own
  // frame) of the given vertices at the current estimate, from the chosen
  // solver's problem; held vertices get zeros. Throws std::invalid_argument
  // for an unknown vertex or one no edge touches; std::runtime_error when
  // the information matrix is singular.
  std::vector<Eigen::MatrixXd> MarginalCovariances(const std::vector<int64_t>& ids,
                                                   SolverKind solver = SolverKind::kGaussNewton);

  const PoseGraph& graph() const { return graph_; }
  SE2 PoseSE2(int64_t id) const { return ToSE2(graph_.vertex(id).x); }
  SE3 PoseSE3(int64_t id) const { return ToSE3(graph_.vertex(id).x); }
  // How many fresh fill-reducing orderings the Gauss-Newton path computed
  // (the rest of its solves reused the previous one).
  int gauss_newton_reorderings() const { return gn_reorderings_; }
  // How many of its solves extended the last symbolic analysis (the graph
  // had only grown by poses and their edges) rather than redoing it.
  int gauss_newton_extensions() const { return gn_extensions_; }

 private:
  void SyncCeres();
  void SyncGaussNewton();
  void PrepareVertex(Vertex& v);
  // The manifold vertex i's block gets under gauge_ (its rotation held or not).
  ceres::Manifold* ManifoldFor(size_t i) const;

  PoseGraph graph_;
  IncrementalOptions options_;
  std::unique_ptr<ceres::Manifold> manifold_;
  std::unique_ptr<ceres::Manifold> held_rotation_;  // a rotation gauge's
  GraphGauge gauge_;  // recomputed at each sync: edges may move it
  // Each solver's loss on loop closures (null: none), shared by its edges.
  std::unique_ptr<ceres::LossFunction> ceres_loss_;
  std::unique_ptr<ceres::LossFunction> gn_loss_;

  std::unique_ptr<ceres::Problem> ceres_;
  size_t ceres_edges_ = 0;  // edges already in the Ceres problem

  std::unique_ptr<PartialUpdater> partial_;
  std::unique_ptr<GaussNewtonProblem> gn_;
  size_t gn_edges_ = 0;
  std::vector<bool> gn_held_;  // per vertex, as last given to the GN problem
  std::vector<bool> gn_rotation_held_;  // likewise
  std::vector<const double*> gn_ordering_;
  size_t gn_ordered_variables_ = 0;  // variables when the ordering was computed
  bool gn_reorder_ = true;
  int gn_reorderings_ = 0;
  int gn_extensions_ = 0;
};

}  // namespace cairn
