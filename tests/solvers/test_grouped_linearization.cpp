// Gauss-Newton without its Jacobians kept (GaussNewtonOptions::
// max_kept_jacobian_bytes = 0): residuals add to b and H group by group as
// they are evaluated. The same steps as with the Jacobians kept, on every
// kind of graph the solver takes, on any thread count.
#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {
namespace {

GaussNewtonOptions Options(bool keep, int threads = 2) {
  GaussNewtonOptions o;
  o.verbose = false;
  o.threads = threads;
  o.max_kept_jacobian_bytes = keep ? GaussNewtonOptions().max_kept_jacobian_bytes : 0;
  return o;
}

// Every vertex (poses and landmarks) within tol of the other graph's.
void ExpectSameEstimate(const PoseGraph& a, const PoseGraph& b, double tol) {
  ASSERT_EQ(a.vertices().size(), b.vertices().size());
  double worst = 0;
  for (size_t i = 0; i < a.vertices().size(); ++i)
    for (int k = 0; k < a.ParameterSize(); ++k)
      worst = std::max(worst, std::abs(a.vertices()[i].x[k] - b.vertices()[i].x[k]));
  EXPECT_LT(worst, tol);
}

struct Case {
  std::string name;
  SimulationOptions sim;
  std::string loss;  // robust loss on loop closures, "" for none
  int fixed_every = 0;
};

class GroupedLinearization : public ::testing::TestWithParam<Case> {};

// Sums run in another order, so the two agree to rounding, not to the bit:
// a last step that changes chi2 only within rounding may go either way.
void ExpectSameSolve(const SolveResult& a, const SolveResult& b) {
  EXPECT_EQ(a.converged, b.converged) << a.termination << " / " << b.termination;
  EXPECT_LE(std::abs(a.iterations - b.iterations), 1);
  for (size_t k = 0; k < std::min(a.trace.size(), b.trace.size()); ++k)
    EXPECT_NEAR(a.trace[k].chi2 / b.trace[k].chi2, 1.0, 1e-9) << "iteration " << k;
  EXPECT_NEAR(a.final_chi2 / b.final_chi2, 1.0, 1e-9);
}

TEST_P(GroupedLinearization, TakesTheStepsOfKeptJacobians) {
  const Case& c = GetParam();
  PoseGraph base = Simulate(c.sim).noisy;
  if (c.fixed_every > 0)
    for (size_t i = 0; i < base.vertices().size(); i += c.fixed_every)
      base.vertex(base.vertices()[i].id).fixed = true;
  PoseGraph kept = base, grouped = base;
  GaussNewtonOptions ok = Options(true), og = Options(false);
  if (!c.loss.empty()) ok.loop_closure_loss = og.loop_closure_loss = ParseRobustLoss(c.loss);
  const SolveResult a = SolveGaussNewton(kept, ok);
  const SolveResult b = SolveGaussNewton(grouped, og);
  ExpectSameSolve(a, b);
  EXPECT_NEAR(b.final_chi2, Chi2(grouped), 1e-9 * b.final_chi2);
  ExpectSameEstimate(kept, grouped, 1e-6);
}

SimulationOptions Sim(int dimension, int poses, uint64_t seed) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = poses;
  o.seed = seed;
  if (dimension == 3) o.nodes_per_lap = 20;
  return o;
}

std::vector<Case> Cases() {
  std::vector<Case> cases;
  cases.push_back({"Plain2D", Sim(2, 600, 3)});
  cases.push_back({"Plain3D", Sim(3, 400, 4)});
  Case landmarks2{"Landmarks2D", Sim(2, 400, 5)};
  landmarks2.sim.landmarks = 30;
  cases.push_back(landmarks2);
  Case landmarks3{"Landmarks3D", Sim(3, 300, 6)};
  landmarks3.sim.landmarks = 20;
  cases.push_back(landmarks3);
  // Rotations far off: refused steps, damping, re-linearisation.
  Case damped{"Damped", Sim(2, 300, 9)};
  damped.sim.rotation_noise = 0.2;
  damped.sim.loop_probability = 1.0;
  cases.push_back(damped);
  Case robust{"Robust", Sim(2, 300, 21)};
  robust.sim.outliers = 5;
  robust.loss = "cauchy:1";
  cases.push_back(robust);
  Case fixed{"FixedVertices", Sim(3, 300, 7)};
  fixed.fixed_every = 37;
  cases.push_back(fixed);
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Graphs, GroupedLinearization, ::testing::ValuesIn(Cases()),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; });

// Within a group no two residuals share a variable, and groups run in
// order: the thread count cannot change a single bit.
TEST(GroupedLinearization, ThreadsDoNotChangeTheResult) {
  SimulationOptions so = Sim(2, 2000, 8);
  so.landmarks = 40;
  PoseGraph one = Simulate(so).noisy, two = one;
  const SolveResult a = SolveGaussNewton(one, Options(false, 1));
  const SolveResult b = SolveGaussNewton(two, Options(false, 2));
  EXPECT_EQ(a.final_chi2, b.final_chi2);
  for (size_t i = 0; i < one.vertices().size(); ++i)
    ASSERT_EQ(one.vertices()[i].x, two.vertices()[i].x) << "vertex " << i;
}

// A landmark seen from more poses than a variable's mask of 64 groups
// tracks: the groups past it must still keep its residuals apart.
TEST(GroupedLinearization, ALandmarkSeenFromHundredsOfPoses) {
  SimulationOptions so = Sim(2, 300, 12);
  so.landmarks = 1;
  so.landmark_range = 1e3;  // every pose sees it
  PoseGraph base = Simulate(so).noisy;
  int observations = 0;
  for (const Edge& e : base.edges()) observations += e.IsLandmark() ? 1 : 0;
  ASSERT_GT(observations, 200);
  PoseGraph kept = base, grouped = base;
  ExpectSameSolve(SolveGaussNewton(kept, Options(true)), SolveGaussNewton(grouped, Options(false)));
  ExpectSameEstimate(kept, grouped, 1e-6);
}

// A problem of general residuals: three blocks of sizes 2, 4 and 3 with the
// middle one constant, so that pairs skip a slot.
struct ThreeBlocks {
  explicit ThreeBlocks(double t) : t_(t) {}
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    r[0] = a[0] + T(t_) * a[1] * a[1] + b[0] * c[0] - T(1);
    r[1] = a[1] * c[1] + b[3] - T(t_) * c[2] * c[2];
    r[2] = T(t_) * a[0] * c[2] - b[1] + c[0] * c[1];
    return true;
  }
  double t_;
};

TEST(GroupedLinearization, GeneralResidualsWithAConstantBlockBetween) {
  auto solve = [](size_t kept_bytes, double (&a)[2][2], double (&c)[2][3]) {
    double b[4] = {1, 2, 3, 4};
    GaussNewtonProblem problem;
    for (int i = 0; i < 6; ++i) {
      const double t = 0.5 + i;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ThreeBlocks, 3, 2, 4, 3>(new ThreeBlocks(t)), nullptr,
          {a[i % 2], b, c[(i / 2) % 2]});
    }
    problem.SetParameterBlockConstant(b);
    GaussNewtonOptions o;
    o.verbose = false;
    o.max_kept_jacobian_bytes = kept_bytes;
    return problem.Solve(o);
  };
  double a1[2][2] = {{0.1, 0.2}, {0.3, -0.1}}, c1[2][3] = {{0.5, 0.4, 0.3}, {-0.2, 0.1, 0.6}};
  double a2[2][2], c2[2][3];
  std::copy(&a1[0][0], &a1[0][0] + 4, &a2[0][0]);
  std::copy(&c1[0][0], &c1[0][0] + 6, &c2[0][0]);
  const SolveResult kept = solve(size_t{1} << 20, a1, c1);
  const SolveResult grouped = solve(0, a2, c2);
  EXPECT_LE(std::abs(kept.iterations - grouped.iterations), 1);
  EXPECT_NEAR(kept.final_chi2, grouped.final_chi2, 1e-12 + 1e-9 * kept.final_chi2);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR((&a1[0][0])[i], (&a2[0][0])[i], 1e-9);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR((&c1[0][0])[i], (&c2[0][0])[i], 1e-9);
}

}  // namespace
}  // namespace cairn
