// Marginal covariances: by hand on one odometry edge from a fixed pose (the
// inverse information, in the pose's own frame), Ceres and the Gauss-Newton
// factorisation agreeing on simulated graphs, and `cairn optimize
// --covariance`.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cairn/solvers/covariance.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

namespace cairn {
namespace {

double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(a.norm(), b.norm());
}

TEST(Covariance, OneEdgeFromAFixedPose2D) {
  PoseGraph g(2);
  g.AddVertex(0, SE2(1, 2, 0.7), /*fixed=*/true);
  const SE2 z(0.8, -0.3, 0.4);
  g.AddVertex(1, SE2(1, 2, 0.7) * z);
  Eigen::Matrix3d info;
  info << 40, 5, 2, 5, 30, -3, 2, -3, 90;
  Edge e;
  e.from = 0;
  e.to = 1;
  e.z = ToParams(z);
  e.information.SetTopLeft(info);
  g.AddEdge(e);
  for (SolverKind s : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
    const auto cov = MarginalCovariances(g, {0, 1}, s);
    // e = delta at the optimum (right perturbation, pose's own frame), so
    // H = Omega: no rotation by the pose's heading.
    EXPECT_LT(RelativeDifference(cov[1], info.inverse()), 1e-9);
    EXPECT_TRUE(cov[0].isZero());
  }
}

TEST(Covariance, OneEdgeFromAFixedPose3D) {
  PoseGraph g(3);
  const SE3 x0(Eigen::Quaterniond(Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 2, 3).normalized())),
               Eigen::Vector3d(1, -2, 0.5));
  const SE3 z = SE3().BoxPlus((Vector6d() << 0.5, 0.1, -0.2, 0.1, -0.3, 0.2).finished());
  g.AddVertex(0, x0, true);
  g.AddVertex(1, x0 * z);
  Matrix6d a = Matrix6d::Random();
  const Matrix6d info = a * a.transpose() + 10 * Matrix6d::Identity();
  Edge e;
  e.from = 0;
  e.to = 1;
  e.z = ToParams(z);
  e.information = info;
  g.AddEdge(e);
  // g2o's error takes the quaternion's vector part, half the rotation vector
  // of the tangent: cov = D Omega^-1 D with D = diag(1, 1, 1, 2, 2, 2).
  const Vector6d d = (Vector6d() << 1, 1, 1, 2, 2, 2).finished();
  const Matrix6d expected = d.asDiagonal() * info.inverse() * d.asDiagonal();
  for (SolverKind s : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
    const auto cov = MarginalCovariances(g, {1}, s);
    EXPECT_LT(RelativeDifference(cov[0], expected), 1e-9);
  }
}

void ExpectSolversAgree(int dimension) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = dimension == 2 ? 300 : 200;
  o.nodes_per_lap = 20;
  o.seed = 9;
  Simulation sim = Simulate(o);
  GaussNewtonOptions gn;
  gn.function_tolerance = 1e-12;
  gn.parameter_tolerance = 1e-12;
  ASSERT_TRUE(SolveGaussNewton(sim.noisy, gn).converged);
  const std::vector<int64_t> ids = {0, 3, 17, 42, o.poses - 1};
  const auto ceres = MarginalCovariances(sim.noisy, ids, SolverKind::kCeres);
  const auto gauss = MarginalCovariances(sim.noisy, ids, SolverKind::kGaussNewton);
  ASSERT_EQ(ceres.size(), ids.size());
  EXPECT_TRUE(ceres[0].isZero());  // the gauge
  EXPECT_TRUE(gauss[0].isZero());
  for (size_t k = 1; k < ids.size(); ++k) {
    ASSERT_EQ(ceres[k].rows(), dimension == 2 ? 3 : 6);
    EXPECT_LT(RelativeDifference(ceres[k], gauss[k]), 1e-6) << "vertex " << ids[k];
    // Uncertainty grows away from the gauge.
    EXPECT_GT(ceres[k].trace(), 0);
  }
  EXPECT_GT(ceres.back().trace(), ceres[1].trace());
}

TEST(Covariance, SolversAgreeOnASimulatedGraph2D) { ExpectSolversAgree(2); }
TEST(Covariance, SolversAgreeOnASimulatedGraph3D) { ExpectSolversAgree(3); }

TEST(Covariance, RefusesUnknownVertices) {
  PoseGraph g(2);
  g.AddVertex(0, SE2());
  g.AddVertex(1, SE2());
  g.AddVertex(2, SE2());
  Edge e;
  e.from = 0;
  e.to = 1;
  g.AddEdge(e);
  EXPECT_THROW(MarginalCovariances(g, {7}), std::invalid_argument);
  EXPECT_THROW(MarginalCovariances(g, {2}), std::invalid_argument);  // in no edge
}

TEST(Covariance, OptimizeCommandPrintsAndReports) {
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_test_covariance";
  std::filesystem::create_directories(dir);
  SimulationOptions o;
  o.poses = 100;
  WriteG2o(Simulate(o).noisy, (dir / "in.g2o").string());
  int status = 0;
  const std::string out = testing::RunCommand(
      std::string(CAIRN_TOOL) + " optimize " + (dir / "in.g2o").string() + " -o " +
          (dir / "out.g2o").string() + " --quiet --covariance 3,17,42 --report " +
          (dir / "report.json").string(),
      &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("vertex 17"), std::string::npos) << out;
  std::ifstream in(dir / "report.json");
  std::stringstream json;
  json << in.rdbuf();
  EXPECT_NE(json.str().find("\"covariance\""), std::string::npos);
  EXPECT_NE(json.str().find("\"42\""), std::string::npos);
  EXPECT_TRUE(std::isfinite(testing::JsonNumber(json.str(), "final_chi2")));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn
