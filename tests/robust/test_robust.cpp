// Robustness: the DCS kernel (its derivatives, and the same optimum from
// Ceres and the Gauss-Newton path with every kernel), a gauge per connected
// component, non-finite starts, `cairn corrupt` and outlier rejection by GNC.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/robust/leverage.h"
#include "cairn/robust/corrupt.h"
#include "cairn/robust/local_consistency.h"
#include "cairn/robust/outliers.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

namespace cairn {
namespace {

// Either solver's options, converging fully.
template <typename Options>
Options Tight() {
  Options o;
  o.function_tolerance = 1e-14;
  o.gradient_tolerance = 1e-14;
  o.parameter_tolerance = 1e-14;
  o.max_iterations = 200;
  return o;
}
CeresOptions QuietCeres() { return Tight<CeresOptions>(); }
GaussNewtonOptions QuietGn() { return Tight<GaussNewtonOptions>(); }

// The simulator's graph: `dim` dimensions, `poses` poses, `outliers` wrong
// loop closures among the loop closures.
Simulation Simulated(int dim, int poses, uint64_t seed, int outliers = 0) {
  SimulationOptions so;
  so.dimension = dim;
  so.poses = poses;
  so.seed = seed;
  so.outliers = outliers;
  return Simulate(so);
}

double RmsPositionDifference(const PoseGraph& a, const PoseGraph& b) {
  double sum = 0;
  for (size_t i = 0; i < a.vertices().size(); ++i)
    for (int k = 0; k < a.dimension(); ++k)
      sum += std::pow(a.vertices()[i].x[k] - b.vertices()[i].x[k], 2);
  return std::sqrt(sum / a.vertices().size());
}

double MaxPositionDifference(const PoseGraph& a, const PoseGraph& b) {
  return ComparePoses(a, b).max_translation;
}

TEST(Dcs, DerivativesMatchNumericDifferentiation) {
  const DcsLoss loss(2.5);
  for (double s : {0.1, 1.0, 2.4, 2.6, 5.0, 40.0, 1e4}) {
    double rho[3], plus[3], minus[3];
    const double h = 1e-6 * std::max(1.0, s);
    loss.Evaluate(s, rho);
    loss.Evaluate(s + h, plus);
    loss.Evaluate(s - h, minus);
    EXPECT_NEAR(rho[1], (plus[0] - minus[0]) / (2 * h), 1e-6) << "s " << s;
    EXPECT_NEAR(rho[2], (plus[1] - minus[1]) / (2 * h), 1e-6) << "s " << s;
    // The DCS weight: the squared scale min(1, 2 phi / (phi + s)).
    const double scale = std::min(1.0, 2 * 2.5 / (2.5 + s));
    EXPECT_NEAR(rho[1], scale * scale, 1e-12) << "s " << s;
  }
  // Continuous at phi, and bounded by 3 phi.
  double below[3], above[3];
  loss.Evaluate(2.5 - 1e-12, below);
  loss.Evaluate(2.5 + 1e-12, above);
  EXPECT_NEAR(below[0], above[0], 1e-9);
  EXPECT_NEAR(below[1], above[1], 1e-9);
  loss.Evaluate(1e12, above);
  EXPECT_LT(above[0], 3 * 2.5);
}

TEST(Dcs, ParsesAndPrints) {
  const RobustLoss d = ParseRobustLoss("dcs:4");
  EXPECT_EQ(d.kind, RobustLoss::kDcs);
  EXPECT_DOUBLE_EQ(d.delta, 4);
  EXPECT_EQ(ToString(d), "dcs:4");
  EXPECT_NE(dynamic_cast<DcsLoss*>(MakeLoss(d).get()), nullptr);
  EXPECT_THROW(ParseRobustLoss("dcs:-1"), std::invalid_argument);
  EXPECT_THROW(ParseRobustLoss("dcs"), std::invalid_argument);
}

// IRLS (Gauss-Newton reweighting by rho') and Ceres (rho with its
// curvature correction) minimise the same robust cost: same optimum.
TEST(RobustKernels, GaussNewtonAndCeresAgreeWithEveryKernel) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (int dim : {2, 3}) {
    const Simulation sim = Simulated(dim, dim == 2 ? 300 : 250, 5, 5);
    for (const char* kernel : {"huber:1", "cauchy:1", "dcs:1"}) {
      PoseGraph by_ceres = sim.noisy, by_gn = sim.noisy;
      CeresOptions co = QuietCeres();
      GaussNewtonOptions go = QuietGn();
      co.loop_closure_loss = go.loop_closure_loss = ParseRobustLoss(kernel);
      const SolveResult rc = SolveWithCeres(by_ceres, co);
      const SolveResult rg = SolveGaussNewton(by_gn, go);
      ASSERT_TRUE(rc.usable && rg.usable) << kernel;
      EXPECT_LT(MaxPositionDifference(by_ceres, by_gn), 1e-3)
          << "dim " << dim << " " << kernel << ": " << rc.message << " / " << rg.message;
      EXPECT_NEAR(rc.final_chi2, rg.final_chi2, 1e-5 * rc.final_chi2) << kernel;
    }
  }
}

TEST(RobustKernels, DcsShrugsOffWrongLoopClosures) {
  const Simulation sim = Simulated(2, 300, 3, 10);
  PoseGraph plain = sim.noisy, dcs = sim.noisy;
  SolveWithCeres(plain, QuietCeres());
  CeresOptions o = QuietCeres();
  o.loop_closure_loss = ParseRobustLoss("dcs:1");
  SolveWithCeres(dcs, o);
  EXPECT_LT(MaxPositionDifference(dcs, sim.truth), 0.5 * MaxPositionDifference(plain, sim.truth));
}

// Two chains no edge joins: each needs its own gauge, else H is singular.
PoseGraph TwoChains() {
  PoseGraph g(2);
  for (int64_t id = 0; id < 10; ++id) g.AddVertex(id, SE2(0.9 * id, 0.1, 0.02 * id));
  for (int64_t id = 100; id < 110; ++id) g.AddVertex(id, SE2(0.1, 1.1 * (id - 100), 0.0));
  auto between = [&](int64_t a, int64_t b, const SE2& z) {
    Edge e;
    e.kind = KindForBetween(a, b);
    e.from = a;
    e.to = b;
    e.z = ToParams(z);
    g.AddEdge(e);
  };
  for (int64_t id = 0; id < 9; ++id) between(id, id + 1, SE2(1, 0, 0));
  for (int64_t id = 100; id < 109; ++id) between(id, id + 1, SE2(0, 1, 0));
  between(0, 5, SE2(5, 0, 0));
  return g;
}

TEST(Components, EachComponentGetsItsOwnGauge) {
  const PoseGraph g = TwoChains();
  const std::vector<bool> held = HeldConstant(g);
  EXPECT_TRUE(held[g.VertexIndex(0)]);
  EXPECT_TRUE(held[g.VertexIndex(100)]);
  EXPECT_EQ(std::count(held.begin(), held.end(), true), 2);

  PoseGraph by_ceres = g, by_gn = g;
  const SolveResult rc = SolveWithCeres(by_ceres, QuietCeres());
  const SolveResult rg = SolveGaussNewton(by_gn, QuietGn());
  EXPECT_TRUE(rc.usable && rc.converged) << rc.message;
  EXPECT_TRUE(rg.usable && rg.converged) << rg.message;
  EXPECT_LT(rc.final_chi2, 1e-12);
  EXPECT_LT(rg.final_chi2, 1e-12);
  // Each gauge keeps its pose.
  EXPECT_EQ(by_gn.vertex(100).x, g.vertex(100).x);
  EXPECT_EQ(by_ceres.vertex(100).x, g.vertex(100).x);
}

TEST(Components, APriorAnchorsItsComponentOnly) {
  PoseGraph g = TwoChains();
  Edge prior;
  prior.kind = EdgeKind::kPrior;
  prior.from = 104;
  prior.z = ToParams(SE2(0, 4, 0));
  g.AddEdge(prior);
  const std::vector<bool> held = HeldConstant(g);
  EXPECT_TRUE(held[g.VertexIndex(0)]);
  EXPECT_EQ(std::count(held.begin(), held.end(), true), 1);
  const SolveResult r = SolveGaussNewton(g, QuietGn());
  EXPECT_TRUE(r.usable) << r.message;
  EXPECT_NEAR(g.vertex(104).x[1], 4, 1e-9);
}

TEST(Divergence, NonFiniteStartIsRefusedNamingTheVertex) {
  for (bool gn : {false, true}) {
    PoseGraph g = TwoChains();
    g.vertex(7).x[0] = std::nan("");
    const SolveResult r = gn ? SolveGaussNewton(g, QuietGn()) : SolveWithCeres(g, QuietCeres());
    EXPECT_EQ(r.termination, "failure");
    EXPECT_FALSE(r.usable);
    EXPECT_NE(r.message.find("vertex 7"), std::string::npos) << r.message;
  }
}

TEST(Divergence, SolversNeverEndWorseThanTheyStart) {
  const Simulation sim = Simulated(2, 200, 9, 20);
  for (bool gn : {false, true}) {
    PoseGraph g = sim.noisy;
    const double start = Chi2(g);
    CeresOptions co = QuietCeres();
    GaussNewtonOptions go = QuietGn();
    co.max_iterations = go.max_iterations = 3;
    const SolveResult r = gn ? SolveGaussNewton(g, go) : SolveWithCeres(g, co);
    EXPECT_TRUE(std::isfinite(r.final_chi2));
    EXPECT_LE(r.final_chi2, start);
    EXPECT_DOUBLE_EQ(Chi2(g), r.final_chi2);
  }
}

TEST(Corrupt, AddsLoopClosuresWithTheMedianInformation) {
  PoseGraph g = Simulated(2, 300, 4).noisy;
  const size_t before = g.edges().size();
  const size_t closures = g.CountEdges(EdgeKind::kLoopClosure);
  PoseGraph again = g;
  const auto added = AddWrongLoopClosures(g, 25, 11);
  ASSERT_EQ(added.size(), 25u);
  EXPECT_EQ(g.edges().size(), before + 25);
  EXPECT_EQ(g.CountEdges(EdgeKind::kLoopClosure), closures + 25);
  std::set<VertexPair> existing;
  for (size_t k = 0; k < before; ++k)
    if (!g.edges()[k].IsPrior()) existing.insert(std::minmax(g.edges()[k].from, g.edges()[k].to));
  for (const auto& [a, b] : added) {
    EXPECT_GE(b - a, 2);
    EXPECT_EQ(existing.count({a, b}), 0u);
  }
  EXPECT_TRUE(g.edges().back().information.isApprox(g.edges()[before - 1].information) ||
              g.edges().back().information.trace() > 0);
  EXPECT_EQ(AddWrongLoopClosures(again, 25, 11), added);  // the seed decides
  EXPECT_THROW(AddWrongLoopClosures(g, -1, 1), std::invalid_argument);
}

TEST(Gnc, ChiSquaredQuantiles) {
  EXPECT_NEAR(ChiSquaredQuantile(0.99, 3), 11.345, 0.05);
  EXPECT_NEAR(ChiSquaredQuantile(0.99, 6), 16.812, 0.05);
  EXPECT_NEAR(ChiSquaredQuantile(0.95, 3), 7.815, 0.05);
}

TEST(Gnc, ChiSquaredQuantilesInTheFarTail) {
  // Table values (and the closed-form survival functions' roots).
  EXPECT_NEAR(ChiSquaredQuantile(0.999, 3), 16.266, 1e-3);
  EXPECT_NEAR(ChiSquaredQuantile(0.999, 6), 22.458, 1e-3);
  EXPECT_NEAR(ChiSquaredQuantile(1 - 1e-6, 3), 30.664, 2e-3);
  EXPECT_NEAR(ChiSquaredQuantile(1 - 1e-8, 6), 48.364, 2e-3);
  EXPECT_NEAR(ChiSquaredQuantile(0.5, 2), 2 * std::log(2.0), 1e-9);
  // Bonferroni: 1000 loop closures at 0.999 each test at 1 - 1e-6.
  EXPECT_DOUBLE_EQ(LoopClosureThreshold(0.999, 3, 1000), ChiSquaredQuantile(1 - 1e-6, 3));
  EXPECT_THROW(LoopClosureThreshold(1.0, 3, 10), std::invalid_argument);
}

// The deleted-residual statistic against the real thing: delete the edge,
// re-solve, and see chi2 fall.
// The fall of chi2 when these edges are deleted and the rest re-solved.
double FallWithout(const PoseGraph& g, const std::set<size_t>& out) {
  PoseGraph without(g.dimension());
  for (const Vertex& v : g.vertices()) without.AddVertex(v.id, v.x, v.fixed);
  for (size_t k = 0; k < g.edges().size(); ++k)
    if (!out.count(k)) without.AddEdge(g.edges()[k]);
  return Chi2(g) - SolveWithCeres(without, QuietCeres()).final_chi2;
}

TEST(Leverage, PredictsTheFallOfChi2WhenALoopClosureIsDeleted) {
  for (int dim : {2, 3}) {
    PoseGraph g = Simulated(dim, dim == 2 ? 200 : 150, 21).noisy;
    SolveWithCeres(g, QuietCeres());
    std::vector<size_t> closures;
    for (size_t k = 0; k < g.edges().size(); ++k)
      if (g.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);
    ASSERT_GE(closures.size(), 10u);
    closures.resize(10);
    const std::vector<double> predicted = DeletedResidualChi2(g, closures);
    for (size_t i = 0; i < closures.size(); ++i) {
      const double fall = FallWithout(g, {closures[i]});
      ASSERT_TRUE(std::isfinite(predicted[i]));
      EXPECT_GT(fall, 0);
      // Exact for a linear problem; these are nearly linear.
      EXPECT_NEAR(predicted[i], fall, 0.02 * fall + 1e-6) << "dim " << dim << " closure " << i;
      // Deleting an edge releases more than its own residual: the rest had
      // bent towards it.
      EXPECT_GE(predicted[i], EdgeChi2(g, g.edges()[closures[i]]) * (1 - 1e-9));
    }
  }
}

// A group's statistic is the fall of chi2 when all its edges go at once:
// checked against re-solving without them, for groups of consecutive loop
// closures and of loop closures far apart; a group of one is the single
// edge's statistic.
TEST(Leverage, PredictsTheFallOfChi2WhenAGroupIsDeleted) {
  for (int dim : {2, 3}) {
    PoseGraph g = Simulated(dim, dim == 2 ? 200 : 150, 22).noisy;
    SolveWithCeres(g, QuietCeres());
    std::vector<size_t> closures;
    for (size_t k = 0; k < g.edges().size(); ++k)
      if (g.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);
    ASSERT_GE(closures.size(), 12u);
    const std::vector<std::vector<size_t>> groups = {
        {closures[0]},
        {closures[1], closures[2]},
        {closures[3], closures[4], closures[5], closures[6]},
        {closures[0], closures.back(), closures[closures.size() / 2]}};
    const std::vector<double> predicted = GroupDeletedResidualChi2(g, groups);
    EXPECT_NEAR(predicted[0], DeletedResidualChi2(g, {closures[0]})[0], 1e-9 * predicted[0]);
    for (size_t i = 0; i < groups.size(); ++i) {
      const double fall = FallWithout(g, {groups[i].begin(), groups[i].end()});
      ASSERT_TRUE(std::isfinite(predicted[i]));
      EXPECT_NEAR(predicted[i], fall, 0.02 * fall + 1e-6) << "dim " << dim << " group " << i;
      // At least the group's own residuals: the rest had bent towards it.
      double own = 0;
      for (size_t k : groups[i]) own += EdgeChi2(g, g.edges()[k]);
      EXPECT_GE(predicted[i], own * (1 - 1e-9));
    }
  }
}

TEST(Leverage, InnovationPredictsTheRiseOfChi2WhenALoopClosureIsAdded) {
  for (int dim : {2, 3}) {
    const PoseGraph full = Simulated(dim, dim == 2 ? 200 : 150, 23).noisy;
    std::vector<size_t> closures;
    for (size_t k = 0; k < full.edges().size(); ++k)
      if (full.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);
    ASSERT_GE(closures.size(), 10u);
    closures.resize(10);
    // The graph without those ten, solved; each is then added back alone.
    PoseGraph g(dim);
    for (const Vertex& v : full.vertices()) g.AddVertex(v.id, v.x, v.fixed);
    std::vector<Edge> candidates;
    for (size_t k = 0; k < full.edges().size(); ++k) {
      if (std::find(closures.begin(), closures.end(), k) != closures.end())
        candidates.push_back(full.edges()[k]);
      else
        g.AddEdge(full.edges()[k]);
    }
    SolveWithCeres(g, QuietCeres());
    const std::vector<InnovationStat> predicted = InnovationChi2(g, candidates);
    const double chi2 = Chi2(g);
    for (size_t i = 0; i < candidates.size(); ++i) {
      PoseGraph with = g;
      with.AddEdge(candidates[i]);
      const double rise = SolveWithCeres(with, QuietCeres()).final_chi2 - chi2;
      ASSERT_TRUE(std::isfinite(predicted[i].chi2));
      EXPECT_GT(rise, 0);
      EXPECT_NEAR(predicted[i].chi2, rise, 0.02 * rise + 1e-6) << "dim " << dim << " closure " << i;
      // Adding an edge costs less than its residual at the estimate: the
      // rest bends towards it.
      EXPECT_LE(predicted[i].chi2, EdgeChi2(g, candidates[i]) * (1 + 1e-9));
    }
  }
}

// The screened statistic: candidates whose bound from the poses' own
// covariance blocks exceeds the screen are not computed exactly, and that
// bound never exceeds the exact statistic; the rest are the exact values.
TEST(Leverage, ScreenedInnovationIsABoundOrTheExactValue) {
  for (int dim : {2, 3}) {
    PoseGraph g = Simulated(dim, dim == 2 ? 300 : 200, 24).noisy;
    const size_t good = g.edges().size();
    AddWrongLoopClosures(g, 30, 7);
    std::vector<Edge> candidates(g.edges().begin() + good, g.edges().end());
    std::vector<bool> keep(g.edges().size(), false);
    std::fill(keep.begin(), keep.begin() + good, true);
    g.KeepEdges(keep);
    for (size_t k = 0; k < good; k += 9)
      if (g.edges()[k].kind == EdgeKind::kLoopClosure) candidates.push_back(g.edges()[k]);
    SolveWithCeres(g, QuietCeres());
    const std::vector<InnovationStat> exact = InnovationChi2(g, candidates);
    std::vector<double> sorted;
    for (const InnovationStat& e : exact) sorted.push_back(e.chi2);
    std::sort(sorted.begin(), sorted.end());
    const double screen = sorted[sorted.size() / 10];
    const std::vector<InnovationStat> screened = InnovationChi2(g, candidates, screen);
    size_t skipped = 0;
    for (size_t i = 0; i < candidates.size(); ++i) {
      ASSERT_TRUE(exact[i].exact);
      if (screened[i].exact) {
        EXPECT_EQ(screened[i].chi2, exact[i].chi2);
      } else {
        ++skipped;
        EXPECT_GT(screened[i].chi2, screen);
        EXPECT_LE(screened[i].chi2, exact[i].chi2 * (1 + 1e-9)) << "dim " << dim << " " << i;
      }
    }
    // The wrong ones are far above the screen: many are not computed.
    EXPECT_GE(skipped, candidates.size() / 4) << "dim " << dim;
  }
}

TEST(Leverage, AWrongLoopClosureTheEstimateBentToFitStandsOut) {
  PoseGraph g = Simulated(2, 300, 5).noisy;
  const size_t good = g.edges().size();
  AddWrongLoopClosures(g, 1, 9);
  // Ten times as certain as the median loop closure: least squares bends
  // the trajectory to fit it.
  Edge certain = g.edges().back();
  certain.information *= 10;
  g.SetEdge(g.edges().size() - 1, certain);
  SolveWithCeres(g, QuietCeres());
  std::vector<size_t> closures;
  for (size_t k = 0; k < g.edges().size(); ++k)
    if (g.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);
  const std::vector<double> d = DeletedResidualChi2(g, closures);
  const double c2 = LoopClosureThreshold(0.999, 3, closures.size());
  // What deleting a loop closure releases in the rest of the graph: the
  // fall of chi2 beyond its own residual. The good ones near the bend have
  // large residuals too, but the wrong one holds the bend.
  double worst_good = 0;
  for (size_t i = 0; i + 1 < closures.size(); ++i) {
    ASSERT_LT(closures[i], good);
    worst_good = std::max(worst_good, d[i] - EdgeChi2(g, g.edges()[closures[i]]));
  }
  const double own = EdgeChi2(g, g.edges().back());
  EXPECT_GT(d.back(), c2);
  EXPECT_GT(d.back(), 5 * own) << "the fall is far larger than its own residual";
  EXPECT_GT(d.back() - own, 2 * worst_good);
}

// GNC judges a loop closure by its residual at the estimate: started where
// least squares has bent the trajectory to fit a wrong loop closure, it
// keeps it. Verification finds it by what deleting it would release.
TEST(Gnc, VerificationRejectsAWrongLoopClosureThatGncKept) {
  // A corridor of 30 poses a metre apart, two good loop closures, and a
  // wrong one, far more certain than the odometry, that says pose 20 is a
  // metre from pose 0. Least squares folds the corridor to fit it.
  PoseGraph reference(2);
  for (int i = 0; i < 30; ++i) reference.AddVertex(i, SE2(i, 0, 0));
  auto between = [](int64_t a, int64_t b, double dx, double info) {
    Edge e;
    e.kind = KindForBetween(a, b);
    e.from = a;
    e.to = b;
    e.z = {dx, 0, 0};
    e.information = Matrix6d::Identity() * info;
    return e;
  };
  for (int i = 0; i + 1 < 30; ++i) reference.AddEdge(between(i, i + 1, 1, 100));
  reference.AddEdge(between(3, 8, 5, 100));
  reference.AddEdge(between(22, 27, 5, 100));
  PoseGraph bent = reference;
  bent.AddEdge(between(0, 20, 1, 1e4));
  SolveWithCeres(bent, QuietCeres());
  const VertexPair wrong{0, 20};
  for (bool gn : {false, true}) {
    const GraphSolver solver = [&](PoseGraph& x, const InnerSolve&) {
      return gn ? SolveGaussNewton(x, QuietGn()) : SolveWithCeres(x, QuietCeres());
    };
    OutlierRejectionOptions options;
    options.consistency_window = 0;  // GNC alone, from the folded estimate
    options.group_window = 0;        // no runs: no swap test either
    options.verify = false;
    PoseGraph g = bent;
    const auto without = SolveRejectingOutliers(g, solver, options);
    ASSERT_EQ(std::count(without.rejected.begin(), without.rejected.end(), wrong), 0)
        << "GNC alone was expected to keep the wrong loop closure";
    EXPECT_GT(RmsPositionDifference(g, reference), 1.0);
    options.verify = true;
    g = bent;
    const auto with = SolveRejectingOutliers(g, solver, options);
    EXPECT_EQ(with.rejected, std::vector<VertexPair>{wrong}) << (gn ? "gn" : "ceres");
    EXPECT_EQ(with.verified, 1);
    EXPECT_LT(RmsPositionDifference(g, reference), 1e-6) << (gn ? "gn" : "ceres");
  }
}

TEST(Gnc, WithoutWrongLoopClosuresEveryStageKeepsThemAll) {
  // Each stage on and off in turn: none may reject a good loop closure, and
  // the result is the plain solve's.
  PoseGraph reference = Simulated(2, 200, 5).noisy;
  const size_t closures = reference.CountEdges(EdgeKind::kLoopClosure);
  ASSERT_GT(closures, 0u);
  const PoseGraph start = reference;
  SolveWithCeres(reference, QuietCeres());
  const double reference_chi2 = Chi2(reference);
  const GraphSolver solver = [](PoseGraph& x, const InnerSolve&) { return SolveWithCeres(x, QuietCeres()); };
  for (int window : {0, 5})
    for (bool verify : {false, true})
      for (bool readmit : {false, true}) {
        OutlierRejectionOptions options;
        options.consistency_window = window;
        options.verify = verify;
        options.readmit = readmit;
        PoseGraph g = start;
        const auto r = SolveRejectingOutliers(g, solver, options);
        const std::string stages = "window " + std::to_string(window) + (verify ? " verify" : "") +
                                   (readmit ? " readmit" : "");
        EXPECT_TRUE(r.rejected.empty()) << stages;
        EXPECT_EQ(r.verified, 0) << stages;
        EXPECT_GE(r.rounds, 2) << stages;  // at least one weighted solve and the last one
        EXPECT_DOUBLE_EQ(r.threshold_chi2, LoopClosureThreshold(0.999, 3, closures)) << stages;
        EXPECT_NEAR(r.solve.final_chi2, reference_chi2, 1e-6 * reference_chi2) << stages;
        EXPECT_LT(MaxPositionDifference(g, reference), 1e-6) << stages;
      }
  OutlierRejectionOptions bad;
  bad.mu_factor = 1;
  PoseGraph g = start;
  EXPECT_THROW(SolveRejectingOutliers(g, solver, bad), std::invalid_argument);
  bad = OutlierRejectionOptions();
  bad.max_rounds = 0;
  EXPECT_THROW(SolveRejectingOutliers(g, solver, bad), std::invalid_argument);
  for (double tolerance : {-1e-4, 1.0, std::nan("")}) {
    bad = OutlierRejectionOptions();
    bad.inner_tolerance = tolerance;
    EXPECT_FALSE(bad.IsValid(nullptr)) << tolerance;
  }
  bad = OutlierRejectionOptions();
  bad.gnc_passes = 0;
  EXPECT_FALSE(bad.IsValid(nullptr));
  bad = OutlierRejectionOptions();
  bad.fresh_check_iterations = -1;
  EXPECT_FALSE(bad.IsValid(nullptr));
  bad = OutlierRejectionOptions();
  bad.threads = -1;
  EXPECT_FALSE(bad.IsValid(nullptr));
}

TEST(Gnc, LocalSupportConfirmsRunsOfGoodLoopClosuresOnly) {
  for (int dim : {2, 3}) {
    PoseGraph g = Simulated(dim, dim == 2 ? 600 : 400, 17).noisy;
    const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
    const auto added = AddWrongLoopClosures(g, static_cast<int>(good / 2), 4);
    const std::set<VertexPair> wrong(added.begin(), added.end());
    const std::vector<int> support = LocalLoopClosureSupport(g, 5, ChiSquaredQuantile(0.999, g.TangentSize()));
    size_t i = 0, good_confirmed = 0, wrong_confirmed = 0;
    for (const Edge& e : g.edges()) {
      if (e.kind != EdgeKind::kLoopClosure) continue;
      const bool is_wrong = wrong.count(std::minmax(e.from, e.to)) > 0;
      (is_wrong ? wrong_confirmed : good_confirmed) += support[i++] > 0;
    }
    ASSERT_EQ(i, support.size());
    EXPECT_GE(good_confirmed, 0.7 * good) << "dim " << dim;
    EXPECT_LE(wrong_confirmed, 0.05 * added.size()) << "dim " << dim;
  }
  PoseGraph g(2);
  EXPECT_THROW(LocalLoopClosureSupport(g, 0, 10), std::invalid_argument);
}

TEST(Gnc, RejectsHalfAsManyWrongAsGoodFromOdometryWithEitherSolver) {
  const Simulation sim = Simulated(2, 500, 31);
  PoseGraph reference = sim.noisy;
  SolveWithCeres(reference, QuietCeres());
  PoseGraph corrupted = sim.noisy;  // its estimate: chained odometry
  const int wrong = static_cast<int>(corrupted.CountEdges(EdgeKind::kLoopClosure) / 2);
  const auto added = AddWrongLoopClosures(corrupted, wrong, 8);
  const std::set<VertexPair> truth(added.begin(), added.end());
  for (bool gn : {false, true}) {
    PoseGraph g = corrupted;
    OutlierRejectionOptions options;
    const auto result = SolveRejectingOutliers(
        g,
        [&](PoseGraph& x, const InnerSolve& limits) {
          GaussNewtonOptions go;
          CeresOptions co;
          if (limits.max_iterations > 0)
            go.max_iterations = co.max_iterations = limits.max_iterations;
          if (limits.tolerance > 0)
            go.function_tolerance = co.function_tolerance = go.gradient_tolerance =
                co.gradient_tolerance = limits.tolerance;
          return gn ? SolveGaussNewton(x, go) : SolveWithCeres(x, co);
        },
        options);
    size_t caught = 0;
    for (const auto& p : result.rejected) caught += truth.count(p);
    EXPECT_EQ(caught, truth.size()) << (gn ? "gn" : "ceres");
    EXPECT_LE(result.rejected.size() - caught, 0.05 * sim.noisy.CountEdges(EdgeKind::kLoopClosure));
    EXPECT_LT(RmsPositionDifference(g, reference), 0.05) << (gn ? "gn" : "ceres");
  }
}

TEST(Gnc, RejectsTheWrongLoopClosuresWithEitherSolver) {
  for (int dim : {2, 3}) {
    const Simulation sim = Simulated(dim, dim == 2 ? 400 : 250, 12);
    PoseGraph reference = sim.noisy;
    SolveWithCeres(reference, QuietCeres());
    PoseGraph corrupted = sim.noisy;
    const int wrong = static_cast<int>(corrupted.CountEdges(EdgeKind::kLoopClosure) / 3);
    const auto added = AddWrongLoopClosures(corrupted, wrong, 3);
    const std::set<VertexPair> truth(added.begin(), added.end());
    for (bool gn : {false, true}) {
      PoseGraph g = corrupted;
      const auto result = SolveRejectingOutliers(g, [&](PoseGraph& x, const InnerSolve&) {
        return gn ? SolveGaussNewton(x, GaussNewtonOptions()) : SolveWithCeres(x, CeresOptions());
      });
      size_t caught = 0;
      for (const auto& p : result.rejected) caught += truth.count(p);
      EXPECT_EQ(caught, truth.size()) << "dim " << dim << (gn ? " gn" : " ceres");
      EXPECT_LE(result.rejected.size() - caught,
                0.05 * sim.noisy.CountEdges(EdgeKind::kLoopClosure));
      EXPECT_LT(RmsPositionDifference(g, reference), 0.05) << "dim " << dim << ", good rejected " << result.rejected.size() - caught;
    }
  }
}

TEST(Cli, CorruptThenOptimizeRejectingOutliers) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(cairn::testing::TempDir()) / ("cairn_robust_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  WriteG2o(Simulated(2, 300, 8).noisy, (dir / "clean.g2o").string());
  int status = 0;
  const std::string tool = CAIRN_TOOL;
  testing::RunCommand(tool + " corrupt " + (dir / "clean.g2o").string() + " -o " +
                          (dir / "bad.g2o").string() + " --outliers 12 --seed 5 2>&1",
                      &status);
  ASSERT_EQ(status, 0);
  std::ifstream list(dir / "bad.g2o.outliers.txt");
  std::string line;
  std::set<std::string> wrong;
  while (std::getline(list, line))
    if (!line.empty() && line[0] != '#') wrong.insert(line);
  ASSERT_EQ(wrong.size(), 12u);
  testing::RunCommand(tool + " optimize " + (dir / "bad.g2o").string() + " -o " +
                          (dir / "out.g2o").string() + " --quiet --reject-outliers --report " +
                          (dir / "r.json").string() + " 2>&1",
                      &status);
  ASSERT_EQ(status, 0);
  std::ifstream in(dir / "r.json");
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = json.find("\"rejected_loop_closures\": [");
  ASSERT_NE(at, std::string::npos) << json;
  for (const std::string& pair : wrong) {
    std::istringstream ss(pair);
    long a, b;
    ss >> a >> b;
    const std::regex listed("\\[\\s*" + std::to_string(a) + ",\\s*" + std::to_string(b) + "\\s*\\]");
    EXPECT_TRUE(std::regex_search(json, listed)) << pair;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cairn
