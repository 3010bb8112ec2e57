// The solvers' options check themselves (IsValid), and the solvers refuse
// options that do not pass, so a program embedding cairn gets the checks
// the `cairn` tool makes.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "cairn/graph/simulate.h"
#include "cairn/robust/outliers.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/incremental.h"

namespace cairn {
namespace {

TEST(Options, DefaultsAreValid) {
  std::string why = "untouched";
  EXPECT_TRUE(SolverOptions().IsValid(&why));
  EXPECT_TRUE(CeresOptions().IsValid(&why));
  EXPECT_TRUE(GaussNewtonOptions().IsValid(&why));
  EXPECT_TRUE(IncrementalOptions().IsValid(&why));
  EXPECT_TRUE(OutlierRejectionOptions().IsValid(&why));
  EXPECT_TRUE(CeresOptions().IsValid(nullptr));
  EXPECT_EQ(why, "untouched");
}

TEST(Options, EachSaysWhatIsWrong) {
  std::string why;
  SolverOptions common;
  common.max_iterations = -1;
  EXPECT_FALSE(common.IsValid(&why));
  EXPECT_NE(why.find("max_iterations"), std::string::npos) << why;
  EXPECT_FALSE(CeresOptions(common).IsValid(&why));
  EXPECT_FALSE(GaussNewtonOptions(common).IsValid(&why));

  CeresOptions ceres;
  ceres.initial_trust_region_radius = 0;
  EXPECT_FALSE(ceres.IsValid(&why));
  EXPECT_NE(why.find("initial_trust_region_radius"), std::string::npos) << why;
  GaussNewtonOptions gn;
  gn.damping = -1;
  EXPECT_FALSE(gn.IsValid(&why));
  IncrementalOptions inc;
  inc.gauss_newton.threads = -2;
  EXPECT_FALSE(inc.IsValid(&why));
  EXPECT_EQ(why.rfind("gauss_newton: ", 0), 0u) << why;
  OutlierRejectionOptions rejection;
  rejection.confidence = 1;
  EXPECT_FALSE(rejection.IsValid(&why));
  EXPECT_NE(why.find("confidence"), std::string::npos) << why;
}

TEST(Options, FromTheCommonOnesKeepsThemAndTheDefaults) {
  SolverOptions common;
  common.max_iterations = 7;
  common.loop_closure_loss = ParseRobustLoss("cauchy:2");
  const CeresOptions ceres(common);
  EXPECT_EQ(ceres.max_iterations, 7);
  EXPECT_EQ(ToString(ceres.loop_closure_loss), "cauchy:2");
  EXPECT_EQ(ceres.initial_trust_region_radius, CeresOptions().initial_trust_region_radius);
  const GaussNewtonOptions gn(common);
  EXPECT_EQ(gn.max_iterations, 7);
  EXPECT_EQ(gn.damping, GaussNewtonOptions().damping);
}

TEST(Options, SolversRefuseInvalidOptions) {
  SimulationOptions so;
  so.poses = 30;
  PoseGraph g = Simulate(so).noisy;
  CeresOptions ceres;
  ceres.threads = -1;
  EXPECT_THROW(SolveWithCeres(g, ceres), std::invalid_argument);
  GaussNewtonOptions gn;
  gn.function_tolerance = -1;
  EXPECT_THROW(SolveGaussNewton(g, gn), std::invalid_argument);
  IncrementalOptions inc;
  inc.reorder_growth = -1;
  EXPECT_THROW(IncrementalOptimizer(2, inc), std::invalid_argument);
  OutlierRejectionOptions rejection;
  rejection.restart_chi2_factor = 1;
  const GraphSolver solve = [](PoseGraph& graph, const InnerSolve&) { return SolveGaussNewton(graph, {}); };
  EXPECT_THROW(SolveRejectingOutliers(g, solve, rejection), std::invalid_argument);
}

TEST(SolverKind, ParsesTheNamesItPrints) {
  for (SolverKind k : {SolverKind::kCeres, SolverKind::kGaussNewton})
    EXPECT_EQ(ParseSolverKind(ToString(k)), k);
  EXPECT_STREQ(ToString(SolverKind::kGaussNewton), "gn");
  EXPECT_THROW(ParseSolverKind("nope"), std::invalid_argument);
}

}  // namespace
}  // namespace cairn
