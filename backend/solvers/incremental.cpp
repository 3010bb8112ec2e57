#include "cairn/solvers/incremental.h"

#include <ceres/solver.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
namespace {


Edge MakeEdge(EdgeKind kind, int64_t from, int64_t to, const PoseParams& z,
              const Eigen::MatrixXd& information) {
  Edge e;
  e.kind = kind;
  e.from = from;
  e.to = to;
  e.z = z;
  e.information.SetTopLeft(information);
  return e;
}


}  // namespace

IncrementalOptimizer::IncrementalOptimizer(int dimension, IncrementalOptions options)
    : graph_(dimension),
      options_(std::move(options)),
      manifold_(dimension == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold()),
      held_rotation_(std::make_unique<HeldRotationManifold>(manifold_.get(), dimension == 2 ? 2 : 3)),
      ceres_loss_(MakeLoss(options_.ceres.loop_closure_loss)),
      gn_loss_(MakeLoss(options_.gauss_newton.loop_closure_loss)) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

IncrementalOptimizer::IncrementalOptimizer(const PoseGraph& graph, IncrementalOptions options)
    : IncrementalOptimizer(graph.dimension(), std::move(options)) {
  graph_ = graph;
}

IncrementalOptimizer::~IncrementalOptimizer() = default;

void IncrementalOptimizer::AddPose(int64_t id, const SE2& x, bool fixed) {
  if (graph_.dimension() != 2) throw std::invalid_argument("an SE2 pose in a 3D graph");
  graph_.AddVertex(id, x, fixed);
}
void IncrementalOptimizer::AddPose(int64_t id, const SE3& x, bool fixed) {
  if (graph_.dimension() != 3) throw std::invalid_argument("an SE3 pose in a 2D graph");
  graph_.AddVertex(id, x, fixed);
}
void IncrementalOptimizer::AddLandmark(int64_t id, const Eigen::Vector3d& p, bool fixed) {
  graph_.AddLandmark(id, p, fixed);
}
void IncrementalOptimizer::AddOdometry(int64_t from, int64_t to, const SE2& z,
                                       const Eigen::Matrix3d& information) {
  AddEdge(MakeEdge(EdgeKind::kOdometry, from, to, ToParams(z), information));
}
void IncrementalOptimizer::AddOdometry(int64_t from, int64_t to, const SE3& z,
                                       const Matrix6d& information) {
  AddEdge(MakeEdge(EdgeKind::kOdometry, from, to, ToParams(z), information));
}
void IncrementalOptimizer::AddLoopClosure(int64_t from, int64_t to, const SE2& z,
                                          const Eigen::Matrix3d& information) {
  AddEdge(MakeEdge(EdgeKind::kLoopClosure, from, to, ToParams(z), information));
}
void IncrementalOptimizer::AddLoopClosure(int64_t from, int64_t to, const SE3& z,
                                          const Matrix6d& information) {
  AddEdge(MakeEdge(EdgeKind::kLoopClosure, from, to, ToParams(z), information));
}
void IncrementalOptimizer::AddPrior(int64_t id, const SE2& z, const Eigen::Matrix3d& information) {
  AddEdge(MakeEdge(EdgeKind::kPrior, id, -1, ToParams(z), information));
}
void IncrementalOptimizer::AddPrior(int64_t id, const SE3& z, const Matrix6d& information) {
  AddEdge(MakeEdge(EdgeKind::kPrior, id, -1, ToParams(z), information));
}

void IncrementalOptimizer::AddEdge(const Edge& edge) { graph_.AddEdge(edge); }

void IncrementalOptimizer::PrepareVertex(Vertex& v) {
  // The factors invert quaternions by conjugation, right only for unit ones.
  if (graph_.dimension() == 3 && !v.landmark)
    Eigen::Map<Eigen::Quaterniond>(v.x.data() + 3).normalize();
}

ceres::Manifold* IncrementalOptimizer::ManifoldFor(size_t i) const {
  if (graph_.vertices()[i].landmark) return nullptr;  // a point: no manifold
  return i < gauge_.rotation_held.size() && gauge_.rotation_held[i] ? held_rotation_.get()
                                                                     : manifold_.get();
}

void IncrementalOptimizer::SyncCeres() {
  // The gauge may move: a prior or a FIX vertex added later frees it.
  gauge_ = ComputeGauge(graph_);
  if (!ceres_) {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres_ = std::make_unique<ceres::Problem>(po);
  }
  const auto& edges = graph_.edges();
  for (; ceres_edges_ < edges.size(); ++ceres_edges_) {
    const Edge& e = edges[ceres_edges_];
    std::vector<double*> blocks{graph_.vertex(e.from).x.data()};
    if (!e.IsPrior()) blocks.push_back(graph_.vertex(e.to).x.data());
    for (double* b : blocks) {
      if (ceres_->HasParameterBlock(b)) continue;
      Vertex& v = graph_.vertex(e.from).x.data() == b ? graph_.vertex(e.from) : graph_.vertex(e.to);
      PrepareVertex(v);
      ceres_->AddParameterBlock(b, graph_.BlockSize(v),
                                v.landmark ? nullptr : ManifoldFor(graph_.VertexIndex(v.id)));
    }
    ceres::LossFunction* loss =
        e.kind == EdgeKind::kLoopClosure ? ceres_loss_.get() : nullptr;
    ceres_->AddResidualBlock(MakeCostFunction(graph_, e), loss, blocks);
  }
  const std::vector<bool>& held = gauge_.held;
  auto& vertices = graph_.vertices();
  for (size_t i = 0; i < vertices.size(); ++i) {
    double* x = vertices[i].x.data();
    if (!ceres_->HasParameterBlock(x)) continue;
    if (ceres_->GetManifold(x) != ManifoldFor(i)) ceres_->SetManifold(x, ManifoldFor(i));
    if (ceres_->IsParameterBlockConstant(x) == held[i]) continue;
    if (held[i]) {
      ceres_->SetParameterBlockConstant(x);
    } else {
      ceres_->SetParameterBlockVariable(x);
    }
  }
}

void IncrementalOptimizer::SyncGaussNewton() {
  if (!gn_) gn_ = std::make_unique<GaussNewtonProblem>();
  gauge_ = ComputeGauge(graph_);
  const auto& edges = graph_.edges();
  for (; gn_edges_ < edges.size(); ++gn_edges_) {
    const Edge& e = edges[gn_edges_];
    std::vector<double*> blocks;
    for (int64_t id : {e.from, e.to}) {
      if (id == e.to && e.IsPrior()) break;
      Vertex& v = graph_.vertex(id);
      // Re-adding a known block only re-sets its manifold: cheap, no lookup needed.
      PrepareVertex(v);
      gn_->AddParameterBlock(v.x.data(), graph_.BlockSize(v),
                             v.landmark ? nullptr : ManifoldFor(graph_.VertexIndex(id)));
      blocks.push_back(v.x.data());
    }
    ceres::LossFunction* loss = e.kind == EdgeKind::kLoopClosure && gn_loss_
                                    ? new BorrowedLoss(gn_loss_.get())
                                    : nullptr;
    gn_->AddResidualBlock(MakeCostFunction(graph_, e), loss, blocks);
  }
  const std::vector<bool>& held = gauge_.held;
  const std::vector<bool> touched = TouchedVertices(graph_);
  auto& vertices = graph_.vertices();
  gn_held_.resize(vertices.size(), false);
  gn_rotation_held_.resize(vertices.size(), false);
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (!touched[i] || gn_rotation_held_[i] == gauge_.rotation_held[i]) continue;
    // Another tangent size: the variables change, order afresh.
    gn_->AddParameterBlock(vertices[i].x.data(), graph_.ParameterSize(), ManifoldFor(i));
    gn_rotation_held_[i] = gauge_.rotation_held[i];
    gn_reorder_ = true;
  }
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (!touched[i] || gn_held_[i] == held[i]) continue;
    // A vertex that changes between held and free changes the variables in
    // the middle of the old ordering: order afresh.
    gn_reorder_ = true;
    gn_held_[i] = held[i];
    if (held[i]) {
      gn_->SetParameterBlockConstant(vertices[i].x.data());
    } else {
      gn_->SetParameterBlockVariable(vertices[i].x.data());
    }
  }
  size_t variables = 0;
  for (size_t i = 0; i < vertices.size(); ++i) variables += touched[i] && !held[i];
  if (!gn_reorder_ && !gn_ordering_.empty() &&
      variables <= static_cast<size_t>((1.0 + options_.reorder_growth) * gn_ordered_variables_)) {
    // Blocks not in the old ordering (the new poses) go last: their edges
    // reach only the end of the elimination, so the old fill stays as it was.
    gn_->SetOrderingHint(gn_ordering_);
  } else {
    gn_reorder_ = true;
    gn_ordered_variables_ = variables;
  }
}

UpdateResult IncrementalOptimizer::Update() {
  const auto start = std::chrono::steady_clock::now();
  if (!partial_)
    partial_ = std::make_unique<PartialUpdater>(&graph_, manifold_.get(), gn_loss_.get(),
                                                options_.partial);
  UpdateResult result;
  // Refused (a step that raised the cost, a factor no longer positive
  // definite, a graph partial updates do not cover): once more from a fresh
  // linearisation at the estimate before it, then the whole solve.
  if (!partial_->Update(&result)) {
    const UpdateResult refused = result;
    partial_->Invalidate();
    if (!partial_->Update(&result)) {
      Optimize(SolverKind::kGaussNewton);
      result.exact = true;
    }
    // The step's own edges and work, which the refused attempt took in.
    result.new_edges += refused.new_edges;
    result.relinearized_vertices += refused.relinearized_vertices;
    result.solved_unknowns += refused.solved_unknowns;
    result.retried += refused.retried;
  }
  result.time_s = Seconds(start);
  return result;
}

SolveResult IncrementalOptimizer::Optimize(SolverKind solver) {
  const auto start = std::chrono::steady_clock::now();
  // The estimate moves under the partial updates' linearisation.
  if (partial_) partial_->Invalidate();
  if (solver == SolverKind::kGaussNewton) {
    SyncGaussNewton();
    const double sync_s = Seconds(start);
    SolveResult result = gn_->Solve(options_.gauss_newton);
    gn_ordering_ = gn_->Ordering();
    if (gn_reorder_) ++gn_reorderings_;
    if (gn_->LastAnalysisExtended()) ++gn_extensions_;
    gn_reorder_ = false;
    result.solver = "gn-incremental";
    result.setup_time_s += sync_s;
    result.time_s += sync_s;
    if (options_.gauss_newton.loop_closure_loss.kind != RobustLoss::kNone)
      result.final_chi2 = Chi2(graph_);
    return result;
  }

  SolveResult result;
  result.solver = "ceres-incremental";
  SyncCeres();
  result.initial_chi2 = Chi2(graph_);
  ceres::Solver::Options so = MakeSolverOptions(graph_, options_.ceres);
  so.minimizer_progress_to_stdout = options_.ceres.verbose;
  RelativeGradientTest gradient_test(options_.ceres.gradient_tolerance, ceres_->NumResiduals());
  so.callbacks.push_back(&gradient_test);
  result.setup_time_s = Seconds(start);
  ceres::Solver::Summary summary;
  SerialLinearAlgebraScope serial;  // for CHOLMOD and BLAS inside Ceres as for ours
  ceres::Solve(so, ceres_.get(), &summary);
  result.final_chi2 = Chi2(graph_);
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.linearize_time_s = summary.jacobian_evaluation_time_in_seconds;
  result.linear_solver_time_s = summary.linear_solver_time_in_seconds;
  SetTermination(summary, gradient_test, &result);
  result.time_s = Seconds(start);
  return result;
}

std::vector<Eigen::MatrixXd> IncrementalOptimizer::MarginalCovariances(
    const std::vector<int64_t>& ids, SolverKind solver) {
  const std::vector<bool> touched = TouchedVertices(graph_);
  std::vector<const double*> blocks;
  for (int64_t id : ids) {
    if (!graph_.HasVertex(id))
      throw std::invalid_argument("no vertex " + std::to_string(id) + " in the graph");
    if (!touched[graph_.VertexIndex(id)])
      throw std::invalid_argument("vertex " + std::to_string(id) +
                                  " is in no edge: it has no covariance");
    blocks.push_back(graph_.vertex(id).x.data());
  }
  if (solver == SolverKind::kCeres) {
    SyncCeres();
    return CeresMarginalCovariances(*ceres_, blocks, ResolveThreads(options_.ceres.threads));
  }
  SyncGaussNewton();
  // Prepare (with the kept ordering when it still applies) without a solve.
  GaussNewtonOptions o = options_.gauss_newton;
  gn_->Prepare(o);
  gn_ordering_ = gn_->Ordering();
  if (gn_reorder_) ++gn_reorderings_;
  if (gn_->LastAnalysisExtended()) ++gn_extensions_;
  gn_reorder_ = false;
  std::vector<Eigen::MatrixXd> out;
  if (!gn_->MarginalCovariances(blocks, &out))
    throw std::runtime_error("the information matrix is singular: some direction is unobserved");
  return out;
}

}  // namespace cairn
