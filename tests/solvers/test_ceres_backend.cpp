// The Ceres back-end: generated graphs with known optima, the gauge, fixed
// vertices, robust losses, the report, and the shared datasets against the
// reference figures (`cairn optimize` is in tests/tools).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "cairn/solvers/solve_result.h"
#include "test_util.h"

namespace cairn {
namespace {

// Replaces every measurement by the exact relative pose of the true
// vertices: the optimum is then the truth itself, at chi2 zero.
void MakeMeasurementsExact(PoseGraph& truth) {
  for (size_t k = 0; k < truth.edges().size(); ++k) {
    Edge e = truth.edges()[k];
    const PoseParams& xi = truth.vertex(e.from).x;
    if (truth.dimension() == 2) {
      e.z = e.IsPrior() ? xi : ToParams(ToSE2(xi).Between(ToSE2(truth.vertex(e.to).x)));
    } else {
      e.z = e.IsPrior() ? xi : ToParams(ToSE3(xi).Between(ToSE3(truth.vertex(e.to).x)));
    }
    truth.SetEdge(k, e);
  }
}

// Moves every vertex but `keep` by noise of about `sigma` (m and rad).
void Perturb(PoseGraph& graph, double sigma, int64_t keep, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<> n(0, sigma);
  for (Vertex& v : graph.vertices()) {
    if (v.id == keep) continue;
    if (graph.dimension() == 2) {
      v.x = ToParams(ToSE2(v.x) * SE2(n(gen), n(gen), n(gen)));
    } else {
      Vector6d d;
      for (int i = 0; i < 6; ++i) d[i] = n(gen);
      v.x = ToParams(ToSE3(v.x).BoxPlus(d));
    }
  }
}

double MaxTranslationError(const PoseGraph& a, const PoseGraph& b) {
  return ComparePoses(a, b).max_translation;
}

double MaxRotationError(const PoseGraph& a, const PoseGraph& b) {
  double worst = 0;
  for (const Vertex& v : a.vertices()) {
    const PoseParams& w = b.vertex(v.id).x;
    const double err = a.dimension() == 2
                           ? std::abs(NormalizeAngle(v.x[2] - w[2]))
                           : QuaternionLog(ToSE3(v.x).rotation().conjugate() *
                                           ToSE3(w).rotation()).norm();
    worst = std::max(worst, err);
  }
  return worst;
}

Simulation Simulated(int dimension, int poses, int outliers = 0, unsigned seed = 7) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = poses;
  o.nodes_per_lap = 20;
  o.radius = 10;
  o.outliers = outliers;
  o.seed = seed;
  return Simulate(o);
}

CeresOptions Quiet() {
  CeresOptions o;
  o.threads = 1;
  return o;
}

// ------------------------------------------------------- generated graphs

class ConvergesToTruth : public ::testing::TestWithParam<std::tuple<int, std::string>> {};

TEST_P(ConvergesToTruth, FromAPerturbedStart) {
  const auto [dimension, variant] = GetParam();
  Simulation sim = Simulated(dimension, 300);
  PoseGraph truth = sim.truth;
  MakeMeasurementsExact(truth);
  ASSERT_GT(truth.CountEdges(EdgeKind::kLoopClosure), 5u);
  PoseGraph graph = truth;
  const int64_t first = graph.vertices().front().id;
  Perturb(graph, 0.05, first, 3);

  CeresOptions o = Quiet();
  if (variant == "dogleg") o.method = CeresOptions::Method::kDogleg;
  if (variant == "suitesparse") o.sparse_library = CeresOptions::SparseLibrary::kSuiteSparse;
  if (variant == "eigen") o.sparse_library = CeresOptions::SparseLibrary::kEigen;
  if (variant == "lm-small-radius") o.initial_trust_region_radius = 1e4;
  o.function_tolerance = 1e-10;
  const SolveResult r = SolveWithCeres(graph, o);

  EXPECT_TRUE(r.usable) << r.message;
  EXPECT_GT(r.initial_chi2, 1.0);
  EXPECT_LT(r.final_chi2, 1e-12) << r.message;
  EXPECT_LT(MaxTranslationError(graph, truth), 1e-6);
  EXPECT_LT(MaxRotationError(graph, truth), 1e-7);
  // The trace: iteration 0 is the start, chi2 there is the initial one.
  ASSERT_FALSE(r.trace.empty());
  EXPECT_EQ(r.trace.front().iteration, 0);
  EXPECT_NEAR(r.trace.front().chi2, r.initial_chi2, 1e-9 * r.initial_chi2);
  EXPECT_NEAR(r.trace.back().chi2, r.final_chi2, 1e-9 + 1e-9 * r.final_chi2);
  EXPECT_EQ(static_cast<int>(r.trace.size()), r.iterations + 1);
  EXPECT_GE(r.time_s, r.linear_solver_time_s);
  EXPECT_FALSE(r.termination.empty());
}

INSTANTIATE_TEST_SUITE_P(
    Variants, ConvergesToTruth,
    ::testing::Combine(::testing::Values(2, 3),
                       ::testing::Values("default", "dogleg", "suitesparse", "eigen",
                                         "lm-small-radius")),
    [](const auto& info) {
      return std::to_string(std::get<0>(info.param)) + "D_" +
             std::regex_replace(std::get<1>(info.param), std::regex("-"), "_");
    });

// A square loop of 2D poses with unsorted, non-zero ids: the gauge is the
// lowest id, not the first inserted.
PoseGraph SquareLoop(std::vector<int64_t> ids) {
  PoseGraph g(2);
  const int n = static_cast<int>(ids.size());
  std::vector<SE2> truth;
  for (int k = 0; k < n; ++k) truth.push_back(SE2(std::cos(2 * M_PI * k / n) * 5,
                                                  std::sin(2 * M_PI * k / n) * 5,
                                                  2 * M_PI * k / n + M_PI / 2));
  for (int k = 0; k < n; ++k) g.AddVertex(ids[k], truth[k]);
  for (int k = 0; k < n; ++k) {
    Edge e;
    e.from = ids[k];
    e.to = ids[(k + 1) % n];
    e.kind = k + 1 < n ? EdgeKind::kOdometry : EdgeKind::kLoopClosure;
    // A little inconsistent, so that the solution moves every free vertex.
    e.z = ToParams(truth[k].Between(truth[(k + 1) % n]) * SE2(0.1, 0.02, 0.01));
    g.AddEdge(e);
  }
  return g;
}

TEST(CeresBackend, GaugeIsTheLowestIdVertex) {
  PoseGraph g = SquareLoop({7, 9, 4, 12, 30, 5, 21});
  const PoseParams held = g.vertex(4).x;
  const PoseGraph start = g;
  {
    CeresGraphProblem p(g, {});
    ASSERT_TRUE(p.gauge_vertex().has_value());
    EXPECT_EQ(*p.gauge_vertex(), 4);
    EXPECT_TRUE(p.problem().IsParameterBlockConstant(g.vertex(4).x.data()));
    EXPECT_EQ(p.problem().NumParameterBlocks(), 7);
  }
  const SolveResult r = SolveWithCeres(g, Quiet());
  EXPECT_LT(r.final_chi2, r.initial_chi2);
  EXPECT_EQ(g.vertex(4).x, held);
  for (int64_t id : {7, 9, 12, 30, 5, 21}) EXPECT_NE(g.vertex(id).x, start.vertex(id).x) << id;
}

TEST(CeresBackend, FixedVerticesDoNotMoveAndNeedNoGauge) {
  PoseGraph g = SquareLoop({0, 1, 2, 3, 4, 5, 6, 7});
  g.vertex(3).fixed = true;
  g.vertex(6).fixed = true;
  const PoseGraph start = g;
  {
    CeresGraphProblem p(g, {});
    EXPECT_FALSE(p.gauge_vertex().has_value());
    EXPECT_FALSE(p.problem().IsParameterBlockConstant(g.vertex(0).x.data()));
  }
  const SolveResult r = SolveWithCeres(g, Quiet());
  EXPECT_LT(r.final_chi2, r.initial_chi2);
  EXPECT_EQ(g.vertex(3).x, start.vertex(3).x);
  EXPECT_EQ(g.vertex(6).x, start.vertex(6).x);
  EXPECT_NE(g.vertex(0).x, start.vertex(0).x);
}

TEST(CeresBackend, PriorsAnchorTheGraphWithoutAGauge) {
  Simulation sim = Simulated(3, 60);
  PoseGraph truth = sim.truth;
  Edge prior;
  prior.kind = EdgeKind::kPrior;
  prior.from = 10;
  truth.AddEdge(prior);
  MakeMeasurementsExact(truth);
  PoseGraph g = truth;
  Perturb(g, 0.05, -1, 5);  // every vertex moves, the first too
  {
    CeresGraphProblem p(g, {});
    EXPECT_FALSE(p.gauge_vertex().has_value());
  }
  CeresOptions o = Quiet();
  o.function_tolerance = 1e-12;
  const SolveResult r = SolveWithCeres(g, o);
  EXPECT_LT(r.final_chi2, 1e-12);
  EXPECT_LT(MaxTranslationError(g, truth), 1e-6);
}

TEST(CeresBackend, OnlyVerticesWithEdgesAreParameterBlocks) {
  PoseGraph g = SquareLoop({0, 1, 2, 3, 4});
  g.AddVertex(99, SE2(1, 2, 3));
  CeresGraphProblem p(g, {});
  EXPECT_EQ(p.problem().NumParameterBlocks(), 5);
  EXPECT_FALSE(p.problem().HasParameterBlock(g.vertex(99).x.data()));
}

TEST(CeresBackend, ThreadsGiveTheSameAnswer) {
  Simulation a = Simulated(2, 400), b = Simulated(2, 400);
  CeresOptions o = Quiet();
  const SolveResult r1 = SolveWithCeres(a.noisy, o);
  o.threads = 2;
  const SolveResult r2 = SolveWithCeres(b.noisy, o);
  EXPECT_NEAR(r1.final_chi2, r2.final_chi2, 1e-9 * r1.final_chi2);
  EXPECT_LT(MaxTranslationError(a.noisy, b.noisy), 1e-8);
}

// Wrong loop closures drag a plain least-squares solution away from the
// truth; a robust loss on loop closures keeps it close.
TEST(CeresBackend, RobustLossDownWeightsWrongLoopClosures) {
  for (const char* kernel : {"huber:1", "cauchy:1"}) {
    Simulation sim = Simulated(2, 400, /*outliers=*/4, /*seed=*/11);
    ASSERT_EQ(sim.outliers.size(), 4u);
    PoseGraph plain = sim.noisy, robust = sim.noisy;
    SolveWithCeres(plain, Quiet());
    CeresOptions o = Quiet();
    o.loop_closure_loss = ParseRobustLoss(kernel);
    const SolveResult r = SolveWithCeres(robust, o);
    EXPECT_TRUE(r.usable);
    const double plain_error = MaxTranslationError(plain, sim.truth);
    const double robust_error = MaxTranslationError(robust, sim.truth);
    EXPECT_LT(robust_error, 0.5 * plain_error) << kernel << ": plain " << plain_error
                                               << " m, robust " << robust_error << " m";
  }
}

TEST(CeresBackend, ParsesRobustLosses) {
  EXPECT_EQ(ParseRobustLoss("none").kind, RobustLoss::kNone);
  EXPECT_EQ(ParseRobustLoss("").kind, RobustLoss::kNone);
  const RobustLoss h = ParseRobustLoss("huber:1.5");
  EXPECT_EQ(h.kind, RobustLoss::kHuber);
  EXPECT_DOUBLE_EQ(h.delta, 1.5);
  const RobustLoss c = ParseRobustLoss("cauchy:0.25");
  EXPECT_EQ(c.kind, RobustLoss::kCauchy);
  EXPECT_DOUBLE_EQ(c.delta, 0.25);
  EXPECT_EQ(ToString(c), "cauchy:0.25");
  // Names in any case, as users type them.
  EXPECT_EQ(ParseRobustLoss("None").kind, RobustLoss::kNone);
  EXPECT_EQ(ParseRobustLoss("Huber:2").kind, RobustLoss::kHuber);
  EXPECT_EQ(ParseRobustLoss("CAUCHY:1").kind, RobustLoss::kCauchy);
  const RobustLoss d = ParseRobustLoss("DCS:3");
  EXPECT_EQ(d.kind, RobustLoss::kDcs);
  EXPECT_EQ(ToString(d), "dcs:3");
  for (const char* bad : {"huber", "huber:", "huber:-1", "huber:0", "huber:x", "tukey:1",
                          "cauchy:1e999", "huber:1 ", "none:1", "NONE:1"})
    EXPECT_THROW(ParseRobustLoss(bad), std::invalid_argument) << bad;
}

TEST(CeresBackend, ReportHasTheAgreedKeys) {
  PoseGraph g = SquareLoop({0, 1, 2, 3, 4, 5});
  const SolveResult r = SolveWithCeres(g, Quiet());
  std::ostringstream os;
  WriteReportJson(r, os, {{"input", "a \"quoted\" name"}, {"vertices", "6"}});
  const std::string json = os.str();
  for (const char* key : {"initial_chi2", "final_chi2", "iterations", "time_s",
                          "linearize_time_s", "linear_solver_time_s", "vertices"})
    EXPECT_FALSE(std::isnan(testing::JsonNumber(json, key))) << key << " in\n" << json;
  EXPECT_DOUBLE_EQ(testing::JsonNumber(json, "final_chi2"), r.final_chi2);
  EXPECT_NE(json.find("\"termination\": \"convergence\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"input\": \"a \\\"quoted\\\" name\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"trace\": ["), std::string::npos);
}

TEST(CeresBackend, FactorEstimateGrowsWithLoops) {
  const FactorEstimate chain = EstimateFactor(SquareLoop({0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(chain.size, 18);
  EXPECT_GT(chain.nonzeros, 0);
  Simulation sim = Simulated(3, 400);
  EXPECT_GT(EstimateFactor(sim.noisy).FlopsPerNonzero(), chain.FlopsPerNonzero());
}

// Ceres's other linear solvers: dense QR (small graphs) and CGNR reach the
// optimum of its sparse Cholesky, in 2D and 3D; dense QR refuses a graph
// too large for it rather than allocate its dense Jacobian.
TEST(CeresBackend, DenseQRAndCGNRReachTheCholeskyOptimum) {
  for (int dimension : {2, 3}) {
    const Simulation sim = Simulated(dimension, dimension == 2 ? 200 : 120);
    PoseGraph cholesky = sim.noisy;
    CeresOptions o;
    o.verbose = false;
    const double reference = SolveWithCeres(cholesky, o).final_chi2;
    for (auto kind : {CeresOptions::LinearSolver::kDenseQR, CeresOptions::LinearSolver::kCGNR}) {
      PoseGraph g = sim.noisy;
      o.linear_solver = kind;
      const SolveResult r = SolveWithCeres(g, o);
      EXPECT_TRUE(r.converged) << r.message;
      EXPECT_NEAR(r.final_chi2 / reference, 1.0, 1e-8) << r.linear_solver;
      EXPECT_LT(ComparePoses(g, cholesky).max_translation, 1e-4) << r.linear_solver;
    }
  }
  PoseGraph large = Simulated(2, 1000).noisy;  // 2997 unknowns
  CeresOptions o;
  o.verbose = false;
  o.linear_solver = CeresOptions::LinearSolver::kDenseQR;
  const SolveResult r = SolveWithCeres(large, o);
  EXPECT_EQ(r.termination, "failure");
  EXPECT_FALSE(r.usable);
  EXPECT_NE(r.message.find("dense QR"), std::string::npos) << r.message;
  EXPECT_EQ(ParseCeresLinearSolver("cg"), CeresOptions::LinearSolver::kCGNR);
  EXPECT_THROW(ParseCeresLinearSolver("supernodal"), std::invalid_argument);
}

// --------------------------------------------------------- the real files

struct Reference {
  const char* file;
  double initial_chi2;  // ../shared/reference-figures.md, ten digits
  double final_chi2;    // the bar, six digits
};

const Reference kReferences[] = {
    {"g2o/2d/intel.g2o", 551.7357308, 45.0047},
    {"g2o/2d/city10000.g2o", 654162688.5, 511.985},
    {"g2o/3d/tinyGrid3D.g2o", 213.0643706, 6.72788},
    {"g2o/3d/smallGrid3D.g2o", 115957.9979, 458.154},
    {"g2o/3d/sphere2500.g2o", 2547810.899, 727.150},
    {"g2o/3d/parking-garage.g2o", 1.6720018170e4, 1.23869},
};

class CeresOnDataset : public ::testing::TestWithParam<Reference> {};

TEST_P(CeresOnDataset, ReachesTheReferenceChi2) {
  const Reference& ref = GetParam();
  const std::string path = testing::DatasetPath(ref.file);
  CAIRN_REQUIRE_DATASET(path);
  PoseGraph graph = ReadGraph(path);
  CeresOptions o;  // the defaults, as `cairn optimize` runs them
  const SolveResult r = SolveWithCeres(graph, o);
  // Six digits: the initial figure to half a unit in the sixth; the final
  // no higher than the bar once rounded to its six digits (the best value
  // known for city10000, 511.9851636, is itself above 511.985 unrounded).
  EXPECT_NEAR(r.initial_chi2 / ref.initial_chi2, 1.0, 5e-7);
  const double half_unit = 0.5 * std::pow(10.0, std::floor(std::log10(ref.final_chi2)) - 5);
  EXPECT_LT(r.final_chi2, ref.final_chi2 + half_unit) << r.message;
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_NEAR(Chi2(graph), r.final_chi2, 1e-12 * r.final_chi2);
  std::printf("[ figures  ] %s: chi2 %.10g -> %.10g, %d iterations, %.3f s (%s)\n", ref.file,
              r.initial_chi2, r.final_chi2, r.iterations, r.time_s, r.linear_solver.c_str());
}

INSTANTIATE_TEST_SUITE_P(SharedFiles, CeresOnDataset, ::testing::ValuesIn(kReferences),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           name = name.substr(name.rfind('/') + 1);
                           return std::regex_replace(name, std::regex("[^A-Za-z0-9]"), "_");
                         });

}  // namespace
}  // namespace cairn
