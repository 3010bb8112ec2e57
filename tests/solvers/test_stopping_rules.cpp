// The stopping rules of both solvers are relative: scaling every information
// matrix by the same factor leaves the iterations and the estimate as they
// are, and `converged` / `usable` mean what solve_result.h says.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "test_util.h"

namespace cairn {
namespace {

PoseGraph Simulated(int dimension, int poses, uint64_t seed) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = poses;
  o.seed = seed;
  return Simulate(o).noisy;
}

using testing::ScaleInformation;

SolveResult Solve(PoseGraph& graph, bool gn, const SolverOptions& common) {
  if (gn) {
    GaussNewtonOptions o;
    static_cast<SolverOptions&>(o) = common;
    // Chord steps end on the function test or at rounding: with only the
    // gradient test in play, every step is a full one.
    o.reuse_factorization = common.function_tolerance > 0;
    return SolveGaussNewton(graph, o);
  }
  CeresOptions o;
  static_cast<SolverOptions&>(o) = common;
  return SolveWithCeres(graph, o);
}

SolverOptions Common() {
  SolverOptions o;
  o.threads = 1;
  return o;
}

// Largest coordinate of any position: what "relative" is relative to.
double Extent(const PoseGraph& graph) {
  double m = 1;
  for (const Vertex& v : graph.vertices())
    for (int k = 0; k < graph.dimension(); ++k) m = std::max(m, std::abs(v.x[k]));
  return m;
}

struct Case {
  int dimension;
  bool gn;
  SolverOptions options;
  const char* name;
  // Ceres's projected gradient is proportional to the tangent one only while
  // small: its gradient test is checked up to this scale.
  double largest_scale = 1e12;
};

class ScaledInformation : public ::testing::TestWithParam<Case> {};

TEST_P(ScaledInformation, SameIterationsAndEstimateAtEveryScale) {
  const Case& c = GetParam();
  for (uint64_t seed : {1, 2}) {
    const PoseGraph start = Simulated(c.dimension, c.dimension == 2 ? 600 : 500, seed);
    PoseGraph reference = start;
    const SolveResult r1 = Solve(reference, c.gn, c.options);
    ASSERT_TRUE(r1.converged) << r1.message;
    ASSERT_GT(r1.iterations, 1);
    for (double s : {1e-12, c.largest_scale}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", information times " + std::to_string(s));
      PoseGraph scaled = start;
      ScaleInformation(scaled, s);
      const SolveResult rs = Solve(scaled, c.gn, c.options);
      EXPECT_EQ(rs.iterations, r1.iterations) << rs.message << " / " << r1.message;
      EXPECT_EQ(rs.termination, r1.termination);
      EXPECT_EQ(rs.converged, r1.converged);
      EXPECT_EQ(rs.usable, r1.usable);
      EXPECT_NEAR(rs.initial_chi2 / s, r1.initial_chi2, 1e-9 * r1.initial_chi2);
      EXPECT_NEAR(rs.final_chi2 / s, r1.final_chi2, 1e-9 * r1.final_chi2);
      // Gauss-Newton ends on a full step taken at the optimum, whose gradient
      // is rounding noise, different at each scale: along the graph's
      // flattest directions it moves poses by a few 1e-9 of the extent.
      const double tolerance = c.gn ? 1e-8 : 1e-9;
      const PoseDifference d = ComparePoses(scaled, reference);
      EXPECT_LE(d.max_translation, tolerance * Extent(reference));
      EXPECT_LE(d.max_rotation_deg, tolerance * 180);
    }
  }
}

SolverOptions GradientOnly() {
  // Only the gradient test can stop these solves.
  SolverOptions o = Common();
  o.function_tolerance = 0;
  o.parameter_tolerance = 0;
  o.gradient_tolerance = 1e-4;
  return o;
}

INSTANTIATE_TEST_SUITE_P(
    BothSolvers, ScaledInformation,
    ::testing::Values(Case{2, true, Common(), "gn2d"}, Case{2, false, Common(), "ceres2d"},
                      Case{3, true, Common(), "gn3d"}, Case{3, false, Common(), "ceres3d"},
                      Case{2, true, GradientOnly(), "gn2d_gradient"},
                      Case{2, false, GradientOnly(), "ceres2d_gradient", 1},
                      Case{3, true, GradientOnly(), "gn3d_gradient"},
                      Case{3, false, GradientOnly(), "ceres3d_gradient", 1}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

// The defect the relative gradient test removes: with tiny information the
// gradient is tiny from the start, and an absolute test stopped the solve
// after one step, centimetres from the optimum, saying "converged".
TEST(TinyInformation, DoesNotStopAfterOneStep) {
  for (bool gn : {true, false}) {
    SCOPED_TRACE(gn ? "gn" : "ceres");
    PoseGraph reference = Simulated(2, 600, 3);
    PoseGraph scaled = reference;
    ScaleInformation(scaled, 1e-12);
    const SolveResult r1 = Solve(reference, gn, Common());
    const SolveResult rs = Solve(scaled, gn, Common());
    EXPECT_GT(rs.iterations, 1) << rs.message;
    EXPECT_TRUE(rs.converged);
    EXPECT_EQ(rs.message.find("gradient"), std::string::npos) << rs.message;
    EXPECT_LE(ComparePoses(scaled, reference).max_translation, 1e-6);
    EXPECT_NEAR(rs.final_chi2 * 1e12, r1.final_chi2, 1e-9 * r1.final_chi2);
  }
}

TEST(GradientTest, StopsRelativeToChi2PerResidual) {
  for (bool gn : {true, false}) {
    SCOPED_TRACE(gn ? "gn" : "ceres");
    PoseGraph graph = Simulated(2, 600, 4);
    const SolveResult r = Solve(graph, gn, GradientOnly());
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_NE(r.message.find("gradient"), std::string::npos) << r.message;
    EXPECT_LT(r.iterations, GradientOnly().max_iterations);
  }
}

// converged: a convergence test stopped the solve; usable: the estimate is
// finite and no worse than the start. Both solvers alike.
TEST(ResultFlags, IterationLimitIsUsableButNotConverged) {
  for (bool gn : {true, false}) {
    SCOPED_TRACE(gn ? "gn" : "ceres");
    PoseGraph graph = Simulated(2, 600, 5);
    SolverOptions o = Common();
    o.max_iterations = 1;
    const SolveResult r = Solve(graph, gn, o);
    EXPECT_EQ(r.termination, "no_convergence") << r.message;
    EXPECT_FALSE(r.converged);
    EXPECT_TRUE(r.usable);
    EXPECT_LT(r.final_chi2, r.initial_chi2);
    EXPECT_TRUE(IsUsableEstimate(r.initial_chi2, r.final_chi2));
  }
}

TEST(ResultFlags, ConvergedMeansTerminationConvergence) {
  for (bool gn : {true, false}) {
    PoseGraph graph = Simulated(3, 300, 6);
    const SolveResult r = Solve(graph, gn, Common());
    EXPECT_EQ(r.converged, r.termination == "convergence") << r.message;
    EXPECT_TRUE(r.converged && r.usable) << r.message;
  }
}

TEST(ResultFlags, UsableRule) {
  EXPECT_TRUE(IsUsableEstimate(10, 10));
  EXPECT_TRUE(IsUsableEstimate(10, 1));
  EXPECT_FALSE(IsUsableEstimate(10, 11));
  EXPECT_FALSE(IsUsableEstimate(10, std::nan("")));
  EXPECT_FALSE(IsUsableEstimate(std::nan(""), std::nan("")));
}

}  // namespace
}  // namespace cairn
