#include "frontend/optimize.h"

#include <ceres/ceres.h>

#include <Eigen/SparseCholesky>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "factors/pose_manifold.h"
#include "factors/se2_factors.h"

namespace cairn::frontend {
namespace {

OptimizeSummary SolveCeres(PoseGraph& graph, const OptimizeOptions& o) {
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  std::unique_ptr<ceres::Manifold> manifold = factors::MakeSE2Manifold();
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    const Eigen::Vector3d z(e.z[0], e.z[1], e.z[2]);
    const Eigen::Matrix3d info = e.information.topLeftCorner<3, 3>();
    ceres::LossFunction* loss =
        e.kind == EdgeKind::kLoopClosure ? new ceres::CauchyLoss(o.robust_scale) : nullptr;
    problem.AddResidualBlock(factors::SE2BetweenFactor::Create(z, info), loss,
                             graph.vertex(e.from).x.data(), graph.vertex(e.to).x.data());
  }
  bool any_fixed = false;
  for (Vertex& v : graph.vertices()) {
    if (!problem.HasParameterBlock(v.x.data())) continue;
    problem.SetManifold(v.x.data(), manifold.get());
    if (v.fixed) {
      problem.SetParameterBlockConstant(v.x.data());
      any_fixed = true;
    }
  }
  if (!any_fixed && !graph.vertices().empty() &&
      problem.HasParameterBlock(graph.vertices().front().x.data()))
    problem.SetParameterBlockConstant(graph.vertices().front().x.data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return {static_cast<int>(summary.iterations.size()), summary.initial_cost, summary.final_cost};
}

// Gauss-Newton with the robust loss as iteratively reweighted least squares.
OptimizeSummary SolveGaussNewton(PoseGraph& graph, const OptimizeOptions& o) {
  std::unique_ptr<ceres::Manifold> manifold = factors::MakeSE2Manifold();
  const size_t n = graph.vertices().size();
  std::vector<int> col(n, -1);
  int free = 0;
  bool any_fixed = graph.CountFixed() > 0;
  for (size_t i = 0; i < n; ++i) {
    const bool fixed = graph.vertices()[i].fixed || (!any_fixed && i == 0);
    if (!fixed) col[i] = 3 * free++;
  }
  struct Term {
    std::unique_ptr<ceres::CostFunction> cost;
    size_t a, b;
    bool robust;
  };
  std::vector<Term> terms;
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    terms.push_back({std::unique_ptr<ceres::CostFunction>(factors::SE2BetweenFactor::Create(
                         Eigen::Vector3d(e.z[0], e.z[1], e.z[2]),
                         e.information.topLeftCorner<3, 3>())),
                     graph.VertexIndex(e.from), graph.VertexIndex(e.to),
                     e.kind == EdgeKind::kLoopClosure});
  }
  const double c2 = o.robust_scale * o.robust_scale;
  auto cost_of = [&](double s, bool robust) { return robust ? 0.5 * c2 * std::log1p(s / c2) : 0.5 * s; };
  OptimizeSummary out;
  double prev_cost = -1;
  for (int it = 0; it < o.max_iterations; ++it) {
    std::vector<Eigen::Triplet<double>> trip;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * free);
    double cost = 0;
    for (const Term& t : terms) {
      double* xa = graph.vertices()[t.a].x.data();
      double* xb = graph.vertices()[t.b].x.data();
      const double* params[2] = {xa, xb};
      Eigen::Vector3d r;
      Eigen::Matrix<double, 3, 3, Eigen::RowMajor> Ja, Jb, Pa, Pb;
      double* jac[2] = {Ja.data(), Jb.data()};
      t.cost->Evaluate(params, r.data(), jac);
      manifold->PlusJacobian(xa, Pa.data());
      manifold->PlusJacobian(xb, Pb.data());
      const Eigen::Matrix3d A = Ja * Pa, B = Jb * Pb;
      const double s = r.squaredNorm();
      cost += cost_of(s, t.robust);
      const double w = t.robust ? 1.0 / (1.0 + s / c2) : 1.0;
      const int ca = col[t.a], cb = col[t.b];
      const Eigen::Matrix3d* J[2] = {&A, &B};
      const int cols[2] = {ca, cb};
      for (int p = 0; p < 2; ++p) {
        if (cols[p] < 0) continue;
        g.segment<3>(cols[p]) += w * J[p]->transpose() * r;
        for (int q = 0; q < 2; ++q) {
          if (cols[q] < 0) continue;
          const Eigen::Matrix3d blk = w * J[p]->transpose() * *J[q];
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) trip.emplace_back(cols[p] + i, cols[q] + j, blk(i, j));
        }
      }
    }
    if (it == 0) out.initial_cost = cost;
    out.final_cost = cost;
    if (prev_cost >= 0 && std::abs(prev_cost - cost) <= 1e-9 * std::max(1.0, prev_cost)) break;
    prev_cost = cost;
    Eigen::SparseMatrix<double> H(3 * free, 3 * free);
    H.setFromTriplets(trip.begin(), trip.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H);
    if (ldlt.info() != Eigen::Success) throw std::runtime_error("Gauss-Newton: singular system");
    const Eigen::VectorXd dx = -ldlt.solve(g);
    for (size_t i = 0; i < n; ++i) {
      if (col[i] < 0) continue;
      double* x = graph.vertices()[i].x.data();
      double moved[3];
      manifold->Plus(x, dx.data() + col[i], moved);
      std::copy(moved, moved + 3, x);
    }
    out.iterations = it + 1;
    if (dx.lpNorm<Eigen::Infinity>() < 1e-8) break;
  }
  return out;
}

}  // namespace

OptimizeSummary OptimizeGraph(PoseGraph& graph, const OptimizeOptions& options) {
  if (graph.dimension() != 2) throw std::invalid_argument("the front-end optimises 2D graphs");
  if (options.solver == "ceres") return SolveCeres(graph, options);
  if (options.solver == "gn") return SolveGaussNewton(graph, options);
  throw std::invalid_argument("unknown solver '" + options.solver + "' (ceres or gn)");
}

}  // namespace cairn::frontend
