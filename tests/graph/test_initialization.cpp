// The initialisers: odometry chaining, the spanning tree and the chordal
// relaxation, on simulated graphs whose truth is known.
#include <gtest/gtest.h>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

#include <fstream>
#include <iterator>

namespace cairn {
namespace {

double MaxTranslationError(const PoseGraph& a, const PoseGraph& b) {
  return ComparePoses(a, b).max_translation;
}

Simulation Noiseless(int dimension) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = 300;
  o.nodes_per_lap = 20;
  o.translation_noise = 0;
  o.rotation_noise = 0;
  o.seed = 4;
  return Simulate(o);
}

// With exact measurements every initialiser must land on the truth.
class ExactMeasurements : public ::testing::TestWithParam<std::tuple<int, InitMethod>> {};

TEST_P(ExactMeasurements, RecoverTheTruth) {
  const auto [dimension, method] = GetParam();
  Simulation sim = Noiseless(dimension);
  PoseGraph g = sim.noisy;
  // Scramble the estimate so that nothing is inherited from it but the root.
  for (size_t i = 1; i < g.vertices().size(); ++i)
    g.vertices()[i].x = dimension == 2 ? ToParams(SE2(5, -3, 1)) : ToParams(SE3());
  const InitReport report = Initialize(g, method);
  EXPECT_LT(MaxTranslationError(g, sim.truth), 1e-9);
  EXPECT_LT(report.chi2, 1e-12);
  EXPECT_GE(report.time_s, 0);
}

INSTANTIATE_TEST_SUITE_P(
    Methods, ExactMeasurements,
    ::testing::Combine(::testing::Values(2, 3),
                       ::testing::Values(InitMethod::kOdometry, InitMethod::kSpanningTree,
                                         InitMethod::kChordal)));

TEST(Chordal, BeatsOdometryOnNoisyRotations) {
  SimulationOptions o;
  o.dimension = 3;
  o.poses = 600;
  o.nodes_per_lap = 30;
  o.rotation_noise = 0.05;
  o.seed = 8;
  o.loop_probability = 1.0;
  const Simulation sim = Simulate(o);
  PoseGraph odo = sim.noisy, chordal = sim.noisy;
  const InitReport a = Initialize(odo, InitMethod::kOdometry);
  const InitReport b = Initialize(chordal, InitMethod::kChordal);
  EXPECT_LT(b.chi2, 0.1 * a.chi2);
  // And the optimiser from the chordal start is at least as good.
  GaussNewtonOptions go;
  go.verbose = false;
  const double from_chordal = SolveGaussNewton(chordal, go).final_chi2;
  const double from_odometry = SolveGaussNewton(odo, go).final_chi2;
  EXPECT_LE(from_chordal, from_odometry * (1 + 1e-9));
}

TEST(Chordal, KeepsFixedVerticesAndEachComponentsRoot) {
  Simulation sim = Noiseless(2);
  PoseGraph g = sim.noisy;
  g.vertex(100).fixed = true;
  const PoseParams fixed = g.vertex(100).x;
  // A second component: two vertices joined by one edge, far away.
  g.AddVertex(1000, SE2(50, 50, 0.5));
  g.AddVertex(1001, SE2(0, 0, 0));
  Edge e;
  e.from = 1000;
  e.to = 1001;
  e.z = ToParams(SE2(1, 0, 0));
  g.AddEdge(e);
  InitializeChordal(g);
  EXPECT_EQ(g.vertex(100).x, fixed);
  const SE2 a = ToSE2(g.vertex(1000).x), b = ToSE2(g.vertex(1001).x);
  EXPECT_NEAR(a.x(), 50, 1e-12);  // the second component's root stays put
  EXPECT_NEAR(b.x(), 50 + std::cos(0.5), 1e-9);
  EXPECT_NEAR(b.y(), 50 + std::sin(0.5), 1e-9);
}

TEST(InitMethods, ParseAndName) {
  for (const char* name : {"file", "odometry", "spanning-tree", "chordal"})
    EXPECT_STREQ(ToString(ParseInitMethod(name)), name);
  EXPECT_THROW(ParseInitMethod("magic"), std::invalid_argument);
}

}  // namespace
}  // namespace cairn

namespace cairn {
namespace {

TEST(OptimizeTool, InitChordalIsReported) {
  const std::string dir = cairn::testing::TempDir();
  int status = -1;
  cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " simulate --poses 200 -o '" + dir +
                                 "/init_sim.g2o' 2>/dev/null",
                             &status);
  ASSERT_EQ(status, 0);
  cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " optimize --quiet --init chordal '" + dir +
                                 "/init_sim.g2o' -o '" + dir + "/init_out.g2o' --report '" + dir +
                                 "/init_report.json'",
                             &status);
  ASSERT_EQ(status, 0);
  std::ifstream in(dir + "/init_report.json");
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"init\": \"chordal\""), std::string::npos) << json;
  const double init_chi2 = cairn::testing::JsonNumber(json, "init_chi2");
  EXPECT_NEAR(init_chi2, cairn::testing::JsonNumber(json, "initial_chi2"), 1e-6 * init_chi2);
  cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " optimize --quiet --init magic '" + dir +
                                 "/init_sim.g2o' -o '" + dir + "/x.g2o' 2>/dev/null",
                             &status);
  EXPECT_EQ(status, 2);
}

}  // namespace
}  // namespace cairn
