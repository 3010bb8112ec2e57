// Aliased wrong loop closures (`cairn corrupt --grouped`), the pairwise
// consistency of loop closures (PCM) and outlier rejection against groups
// of wrong loop closures that agree with each other; on simulated graphs,
// several seeds, both solvers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <tuple>

#include "cairn/graph/chi2.h"
#include "cairn/graph/geometry.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/simulate.h"
#include "cairn/robust/corrupt.h"
#include "cairn/robust/outliers.h"
#include "cairn/robust/pairwise_consistency.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "test_util.h"

namespace cairn {
namespace {

Simulation Simulated(int dim, int poses, uint64_t seed) {
  SimulationOptions so;
  so.dimension = dim;
  so.poses = poses;
  so.seed = seed;
  return Simulate(so);
}

double Rms(const PoseGraph& a, const PoseGraph& b) {
  double sum = 0;
  for (size_t i = 0; i < a.vertices().size(); ++i)
    for (int k = 0; k < a.dimension(); ++k)
      sum += std::pow(a.vertices()[i].x[k] - b.vertices()[i].x[k], 2);
  return std::sqrt(sum / a.vertices().size());
}

// The cycle closure k of a group makes with closure 0 and the true
// odometry: identity when both measure one rigid offset.
template <typename Pose>
double GroupCycleError(const PoseGraph& truth, const Edge& first, const Edge& e) {
  auto x = [&](int64_t id) { return ToPose<Pose>(truth.vertex(id).x); };
  const Pose c = ToPose<Pose>(first.z).Inverse() * x(first.from).Inverse() * x(e.from) *
                 ToPose<Pose>(e.z) * x(e.to).Inverse() * x(first.to);
  return LogMap(c).norm();
}

TEST(Corrupt, AliasedGroupsAgreeWithEachOtherAndTheOdometry) {
  for (int dim : {2, 3})
    for (uint64_t seed : {1, 2, 3}) {
      const Simulation sim = Simulated(dim, 400, seed);
      PoseGraph g = sim.noisy;
      const size_t before = g.edges().size();
      std::set<VertexPair> joined;
      for (const Edge& e : g.edges()) joined.insert(std::minmax(e.from, e.to));
      const auto added = AddAliasedLoopClosures(g, 23, 5, seed, &sim.truth);
      ASSERT_EQ(added.size(), 23u);
      ASSERT_EQ(g.edges().size(), before + 23);
      // Groups of 5, the last of 3: ends step together inside a group.
      for (size_t k = 0; k < added.size(); ++k) {
        const Edge& e = g.edges()[before + k];
        EXPECT_EQ(e.kind, EdgeKind::kLoopClosure);
        EXPECT_EQ(joined.count(added[k]), 0u);
        EXPECT_GE(e.to - e.from, 2);
        const Edge& first = g.edges()[before + k - k % 5];
        EXPECT_EQ(e.from - first.from, static_cast<int64_t>(k % 5));
        EXPECT_EQ(e.to - first.to, static_cast<int64_t>(k % 5));
        const double err = dim == 2 ? GroupCycleError<SE2>(sim.truth, first, e)
                                    : GroupCycleError<SE3>(sim.truth, first, e);
        EXPECT_LT(err, 1e-9) << "dim " << dim << " seed " << seed << " closure " << k;
      }
      // The seed decides; a bad size is refused.
      PoseGraph again = sim.noisy;
      EXPECT_EQ(AddAliasedLoopClosures(again, 23, 5, seed, &sim.truth), added);
      EXPECT_THROW(AddAliasedLoopClosures(again, 5, 0, seed), std::invalid_argument);
    }
}

TEST(PairwiseConsistency, GoodPairsNearAndFarAreChiSquared) {
  // With the simulator's information matching its noise, the cycle of two
  // good loop closures has chi2 with 3 or 6 degrees of freedom: its mean is
  // the dof for near pairs (short cycles), and for far ones (long odometry)
  // in 3D. In 2D the far cycles' mean is about half the dof (the propagated
  // covariance is conservative there, docs/robustness.md): never above it.
  for (int dim : {2, 3}) {
    const PoseGraph g = Simulated(dim, dim == 2 ? 1500 : 1000, 7).noisy;
    const CycleTester t(g);
    ASSERT_GT(t.size(), 100u);
    double near_sum = 0, far_sum = 0;
    size_t near_n = 0, far_n = 0;
    for (size_t i = 0; i < t.size(); ++i)
      for (size_t j = i + 1; j < t.size(); j += 7) {
        const double c = t.PairChi2(i, j);
        ASSERT_TRUE(std::isfinite(c));
        const auto [ai, bi] = t.Ends(i);
        const auto [aj, bj] = t.Ends(j);
        const int64_t span = std::min(std::abs(ai - aj) + std::abs(bi - bj),
                                      std::abs(ai - bj) + std::abs(bi - aj));
        (span <= 20 ? near_sum : far_sum) += c;
        (span <= 20 ? near_n : far_n) += 1;
      }
    ASSERT_GT(near_n, 20u);
    ASSERT_GT(far_n, 1000u);
    const int dof = g.TangentSize();
    EXPECT_NEAR(near_sum / near_n, dof, 0.35 * dof) << "dim " << dim;
    if (dim == 3) EXPECT_NEAR(far_sum / far_n, dof, 0.2 * dof) << "dim " << dim;
    EXPECT_GT(far_sum / far_n, 0.35 * dof) << "dim " << dim;
    EXPECT_LT(far_sum / far_n, 1.2 * dof) << "dim " << dim;
  }
}

// Wrong and good loop closures among those in `in`, in edge order.
std::pair<size_t, size_t> Counts(const PoseGraph& g, const std::vector<bool>& in,
                                 const std::set<VertexPair>& wrong) {
  size_t i = 0, w = 0, good = 0;
  for (const Edge& e : g.edges()) {
    if (e.kind != EdgeKind::kLoopClosure) continue;
    if (in[i++]) (wrong.count(std::minmax(e.from, e.to)) ? w : good) += 1;
  }
  return {w, good};
}

TEST(PairwiseConsistency, TheLargestConsistentSetLeavesAliasedGroupsOut) {
  for (int dim : {2, 3})
    for (uint64_t seed : {4, 5, 6}) {
      const Simulation sim = Simulated(dim, dim == 2 ? 800 : 600, seed);
      PoseGraph g = sim.noisy;
      const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
      const int n_wrong = static_cast<int>(good / 5);
      const auto added = AddAliasedLoopClosures(g, n_wrong, 10, seed, &sim.truth);
      const std::set<VertexPair> wrong(added.begin(), added.end());
      ConsistentSetOptions o;
      o.threshold_chi2 = LoopClosureThreshold(0.999, g.TangentSize(), good + added.size());
      const ConsistentSet set = MaximumConsistentSet(g, o);
      EXPECT_FALSE(set.exact);
      const auto [w, kept] = Counts(g, set.in, wrong);
      EXPECT_LE(w, 0.05 * added.size()) << "dim " << dim << " seed " << seed;
      EXPECT_GE(kept, 0.9 * good) << "dim " << dim << " seed " << seed;
    }
}

TEST(PairwiseConsistency, TheSetDoesNotDependOnTheThreadCount) {
  const Simulation sim = Simulated(2, 800, 8);
  PoseGraph g = sim.noisy;
  const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
  const auto added = AddAliasedLoopClosures(g, static_cast<int>(good / 5), 5, 8, &sim.truth);
  ASSERT_FALSE(added.empty());
  ConsistentSetOptions o;
  o.threshold_chi2 = LoopClosureThreshold(0.999, g.TangentSize(), good + added.size());
  o.threads = 1;
  const ConsistentSet one = MaximumConsistentSet(g, o);
  ASSERT_FALSE(one.exact);
  for (int threads : {2, 3, 7}) {
    o.threads = threads;
    const ConsistentSet many = MaximumConsistentSet(g, o);
    EXPECT_EQ(many.in, one.in) << threads;
    EXPECT_EQ(many.supported, one.supported) << threads;
    EXPECT_EQ(many.tested_pairs, one.tested_pairs) << threads;
    EXPECT_EQ(many.conflicts, one.conflicts) << threads;
    EXPECT_EQ(many.variance_factor, one.variance_factor) << threads;
  }
}

TEST(PairwiseConsistency, ExactForFewLoopClosures) {
  // Few loop closures: every pair tested, the set found is consistent and
  // no loop closure outside it agrees with all of it (maximal), and it is at
  // least as large as the greedy one.
  for (uint64_t seed : {1, 2, 3}) {
    const Simulation sim = Simulated(2, 110, seed);
    PoseGraph g = sim.noisy;
    const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
    ASSERT_LT(good + 10, 60u);
    AddAliasedLoopClosures(g, 10, 5, seed, &sim.truth);
    ConsistentSetOptions o;
    o.threshold_chi2 = LoopClosureThreshold(0.999, 3, good + 10);
    const ConsistentSet exact = MaximumConsistentSet(g, o);
    ASSERT_TRUE(exact.exact);
    const CycleTester t(g);
    EXPECT_EQ(exact.tested_pairs, t.size() * (t.size() - 1) / 2);
    auto agrees = [&](size_t i, size_t j) { return !(t.PairChi2(i, j) > o.threshold_chi2); };
    for (size_t i = 0; i < t.size(); ++i) {
      bool with_all = true;
      for (size_t j = 0; j < t.size(); ++j)
        if (j != i && exact.in[j] && !agrees(i, j)) with_all = false;
      if (exact.in[i]) EXPECT_TRUE(with_all) << i;
      else EXPECT_FALSE(with_all) << i;
    }
    o.exact_limit = 0;
    const ConsistentSet greedy = MaximumConsistentSet(g, o);
    EXPECT_FALSE(greedy.exact);
    EXPECT_GE(std::count(exact.in.begin(), exact.in.end(), true),
              std::count(greedy.in.begin(), greedy.in.end(), true));
  }
}

GraphSolver Solver(bool gn) {
  return [gn](PoseGraph& x, const InnerSolve& limits) {
    GaussNewtonOptions go;
    CeresOptions co;
    if (limits.max_iterations > 0) go.max_iterations = co.max_iterations = limits.max_iterations;
    if (limits.tolerance > 0)
      go.function_tolerance = co.function_tolerance = go.gradient_tolerance =
          co.gradient_tolerance = limits.tolerance;
    return gn ? SolveGaussNewton(x, go) : SolveWithCeres(x, co);
  };
}

TEST(Gnc, RejectsAliasedGroupsWithEitherSolver) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (int dim : {2, 3})
    for (uint64_t seed : {21, 22}) {
      const Simulation sim = Simulated(dim, dim == 2 ? 600 : 400, seed);
      PoseGraph reference = sim.noisy;
      SolveWithCeres(reference, CeresOptions());
      PoseGraph corrupted = sim.noisy;
      const size_t good = corrupted.CountEdges(EdgeKind::kLoopClosure);
      const int size = seed % 2 ? 5 : 10;
      const auto added = AddAliasedLoopClosures(corrupted, static_cast<int>(good / 5), size,
                                                seed, &sim.truth);
      const std::set<VertexPair> wrong(added.begin(), added.end());
      for (bool gn : {false, true}) {
        PoseGraph g = corrupted;
        const auto r = SolveRejectingOutliers(g, Solver(gn));
        size_t caught = 0;
        for (const auto& p : r.rejected) caught += wrong.count(p);
        const std::string what = "dim " + std::to_string(dim) + " seed " +
                                 std::to_string(seed) + (gn ? " gn" : " ceres");
        EXPECT_GE(caught, 0.95 * wrong.size()) << what;
        EXPECT_LE(r.rejected.size() - caught, 0.05 * good) << what;
        EXPECT_LT(Rms(g, reference), 0.05) << what;
        // The whole run's figures: the kept graph's chi2 at the end.
        EXPECT_NEAR(r.solve.final_chi2, Chi2(WithoutEdges(g, r.rejected_edges)),
                    1e-9 * r.solve.final_chi2);
        EXPECT_GE(r.iterations, r.solve.iterations);
      }
    }
}

// A shared file with aliased wrong loop closures as the robustness table
// makes them (measured on the clean solution), and that solution.
struct AliasedFile {
  PoseGraph reference{2}, corrupted{2};
  std::set<VertexPair> wrong;
};

// `init`: where the reference solve starts (the file's vertices by default;
// MIT's lead to a worse minimum than the chordal relaxation's).
AliasedFile ReadAliased(const std::string& path, int count, int size, uint64_t seed,
                        InitMethod init = InitMethod::kFile) {
  AliasedFile f;
  f.reference = ReadGraph(path);
  if (init != InitMethod::kFile) Initialize(f.reference, init);
  SolveWithCeres(f.reference, CeresOptions());
  f.corrupted = ReadGraph(path);
  const auto added = AddAliasedLoopClosures(f.corrupted, count, size, seed, &f.reference);
  f.wrong.insert(added.begin(), added.end());
  return f;
}

// --reject-outliers on the file with the chosen solver: every wrong loop
// closure rejected, no good one, and the clean solution reached. Returns the
// result for further checks.
OutlierRejectionResult ExpectExactRejection(const AliasedFile& f, bool gn,
                                            const std::string& what) {
  PoseGraph g = f.corrupted;
  const auto r = SolveRejectingOutliers(g, Solver(gn));
  size_t caught = 0;
  for (const auto& p : r.rejected) caught += f.wrong.count(p);
  EXPECT_EQ(caught, f.wrong.size()) << what;
  EXPECT_EQ(r.rejected.size(), caught) << what;
  EXPECT_LT(Rms(g, f.reference), 1e-3) << what;
  return r;
}

// manhattan with 98 wrong loop closures in aliased groups of 10 (seed 995,
// the robustness table's case): one group links two stretches nothing else
// links, and GNC keeps it, bent into place (each member fits within 0.1 of
// chi2, deleting any one lowers chi2 by under 0.5: the other nine hold the
// bend). Deleting the run lowers chi2 by about 480, more than its 10 c^2:
// the run verification rejects it whole, with either solver, and the result
// is the clean file's. Without it, 13.9 m RMS.
TEST(Gnc, AWrongRunGncKeepsIsRejectedWhole) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/2d/manhattan.g2o");
  CAIRN_REQUIRE_DATASET(path);
  const AliasedFile f = ReadAliased(path, 98, 10, 995);
  const PoseGraph& reference = f.reference;
  const PoseGraph& corrupted = f.corrupted;
  const std::set<VertexPair>& wrong = f.wrong;
  for (int window : {0, 3})
    for (bool gn : {false, true}) {
      if (window == 0 && gn) continue;
      OutlierRejectionOptions o;
      o.group_window = window;
      PoseGraph g = corrupted;
      const auto r = SolveRejectingOutliers(g, Solver(gn), o);
      size_t caught = 0;
      for (const auto& p : r.rejected) caught += wrong.count(p);
      const std::string what = std::string(gn ? "gn" : "ceres") + " window " +
                               std::to_string(window);
      if (window == 0) {
        EXPECT_LE(caught, wrong.size() - 10) << "the case no longer needs the run test";
        continue;
      }
      EXPECT_EQ(caught, wrong.size()) << what;
      EXPECT_EQ(r.rejected.size(), caught) << what;
      EXPECT_GE(r.verified, 10) << what;
      EXPECT_LT(Rms(g, reference), 1e-3) << what;
    }
}

// With sphere2500's noise (0.3 m, 0.05 rad) the final solve from a fresh
// start lands the kept graph in another basin than the stages' estimate;
// good loop closures rejected there fit again and must come back. Before
// they were taken back after that solve too, this case rejected 123 good.
TEST(Gnc, NoRejectedLoopClosureFitsTheFinalSolution) {
  CAIRN_LONG_NUMERICAL_TEST();
  SimulationOptions so;
  so.dimension = 3;
  so.poses = 1000;
  so.seed = 2;
  so.translation_noise = 0.3;
  so.rotation_noise = 0.05;
  const Simulation sim = Simulate(so);
  PoseGraph g = sim.noisy;
  const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
  const auto added = AddAliasedLoopClosures(g, static_cast<int>(std::lround(0.1 * good)), 5,
                                            so.seed, &sim.truth);
  const std::set<VertexPair> wrong(added.begin(), added.end());
  const PoseGraph corrupted = g;
  const auto r = SolveRejectingOutliers(g, Solver(false));
  size_t caught = 0, fitting = 0;
  for (size_t i = 0; i < r.rejected.size(); ++i) {
    caught += wrong.count(r.rejected[i]);
    fitting += EdgeChi2(g, corrupted.edges()[r.rejected_edges[i]]) <= r.threshold_chi2;
  }
  EXPECT_EQ(caught, wrong.size());
  EXPECT_LE(r.rejected.size() - caught, 0.01 * good);
  EXPECT_EQ(fitting, 0u);
}

// Every wrong loop closure rejected, no good one, and the clean solution.
void ExpectExactVerdicts(const OutlierRejectionResult& r, const std::set<VertexPair>& wrong,
                         double rms, uint64_t seed) {
  size_t caught = 0;
  for (const auto& p : r.rejected) caught += wrong.count(p);
  EXPECT_EQ(caught, wrong.size()) << "seed " << seed;
  EXPECT_EQ(r.rejected.size() - caught, 0u) << "seed " << seed;
  EXPECT_LT(rms, 1e-3) << "seed " << seed;
}

// Information looser than the noise (0.3 times its inverse covariance), and
// one loop closure in ten with 3 times more noise on top: the good ones'
// statistics have a heavier tail than chi2's, as intel's and manhattan's
// do. The variance factor then tightens the re-admission bound into that
// tail; good loop closures must still come back (with the factor's bound
// alone, 2 good ones stayed out per seed, 0.01-0.014 m off), the wrong
// groups stay out.
TEST(Gnc, HeavyTailedGoodLoopClosuresComeBack) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (uint64_t seed : {31, 32, 33}) {
    Simulation sim = Simulated(2, 1500, seed);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    size_t i = 0;
    for (size_t j = 0; j < sim.noisy.edges().size(); ++j) {
      Edge e = sim.noisy.edges()[j];
      if (e.kind == EdgeKind::kLoopClosure && i++ % 10 == 0)
        for (int k = 0; k < 3; ++k) e.z[k] += n01(rng) * 3 * (k < 2 ? 0.05 : 0.01);
      e.information = 0.3 * Matrix6d(e.information);
      sim.noisy.SetEdge(j, e);
    }
    PoseGraph reference = sim.noisy;
    SolveWithCeres(reference, CeresOptions());
    PoseGraph g = sim.noisy;
    const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
    const auto added = AddAliasedLoopClosures(g, static_cast<int>(good / 10), 10, seed,
                                              &sim.truth);
    const std::set<VertexPair> wrong(added.begin(), added.end());
    const auto r = SolveRejectingOutliers(g, Solver(false));
    ExpectExactVerdicts(r, wrong, Rms(g, reference), seed);
  }
}

// Information far looser than the noise (sphere2500's variance factor is
// 0.03) puts the wide reach's mu on the trusted loop closures at a few
// thousandths. Where no wrong one is among them, their least squares
// converges, and the rounds from there up to the residuals' own convex
// start only weigh the heavy tail of good ones: they are skipped, with
// the same verdicts.
TEST(Gnc, ACleanTrustedSetSkipsTheWideReachsRounds) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (uint64_t seed : {41, 42}) {
    PoseGraph loose = Simulated(2, 1000, seed).noisy;
    testing::ScaleInformation(loose, 0.03);
    PoseGraph reference = loose;
    SolveGaussNewton(reference, GaussNewtonOptions());
    PoseGraph g = loose;
    const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
    const auto added = AddWrongLoopClosures(g, static_cast<int>(0.3 * good), seed);
    const std::set<VertexPair> wrong(added.begin(), added.end());
    const auto r = SolveRejectingOutliers(g, Solver(true));
    ExpectExactVerdicts(r, wrong, Rms(g, reference), seed);
    // Solves in the whole run: 7 on either seed, 15 from the wide reach.
    EXPECT_LE(r.rounds, 10) << "seed " << seed;
  }
}

// sphere2500's information is far looser than its noise (variance factor
// 0.03, so GNC's threshold is tightened to 1.2 against a plain 41), and
// the least squares on the trusted loop closures is capped at 20
// iterations: with 20% wrong ones in aliased groups of 10 (the robustness
// table's case) its estimate is still bent. GNC on the trusted ones then
// started with everything beyond 10 times the tightened threshold at
// weight 0: 1,056 of 2,491 good ones never came back, and Gauss-Newton's
// kept graph, held by too few, settled 78 m off. parking-garage (variance
// factor 0.001) with 20% in groups of 5 ended 47 m off the same way, and
// 90% of its trusted loop closures were within that reach: widening it
// only that far was not enough.
TEST(Gnc, TrustedLoopClosuresFarFromAnUnfinishedSolveStayIn) {
  CAIRN_LONG_NUMERICAL_TEST();
  struct Case {
    const char* file;
    int count, size;
    uint64_t seed;  // scripts/robustness.sh's for the case
  };
  for (const Case& c : {Case{"g2o/3d/sphere2500.g2o", 490, 10, 1092},
                        Case{"g2o/3d/parking-garage.g2o", 923, 5, 1482}}) {
    const std::string path = testing::DatasetPath(c.file);
    CAIRN_REQUIRE_DATASET(path);
    ExpectExactRejection(ReadAliased(path, c.count, c.size, c.seed), true, c.file);
  }
}

// A fresh start made with an aliased group that the pairwise tests
// confirmed is bent to it; least squares and GNC's first rounds then spend
// tens of iterations bending the graph further and back. The start is made
// again without the trusted loop closures beyond its reach, until the set
// repeats: the wrong ones move away from it, and each solve after takes a
// few iterations. Simulated 3D graphs of 2,500 poses with 20% wrong loop
// closures in aliased groups of 10: 78-93 iterations in the whole run
// without the screen (GNC's mu x2 a round; information as simulated or
// 0.03 times it, seeds 1 and 2), 27-28 with it, 21-24 with mu x4 as well;
// 2D graphs and 1,000 poses took 20-27 with and without the screen.
TEST(Gnc, TheFreshStartLeavesOutTheAliasedGroupsItCannotHold) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (uint64_t seed : {1, 2}) {
    const Simulation sim = Simulated(3, 2500, seed);
    PoseGraph reference = sim.noisy;
    SolveGaussNewton(reference, GaussNewtonOptions());
    PoseGraph g = sim.noisy;
    const size_t good = g.CountEdges(EdgeKind::kLoopClosure);
    const auto added =
        AddAliasedLoopClosures(g, static_cast<int>(good / 5), 10, seed, &sim.truth);
    const std::set<VertexPair> wrong(added.begin(), added.end());
    const auto r = SolveRejectingOutliers(g, Solver(true));
    ExpectExactVerdicts(r, wrong, Rms(g, reference), seed);
    EXPECT_LE(r.iterations, 40) << "seed " << seed;
  }
}

// parking-garage's information is about 3,000 times looser than its
// residuals (variance factor 0.0003): the whole kept graph's chi2 is under
// 10, a single plain c^2 is 42. With 20% wrong loop closures in aliased
// groups of 10 (the table's seed for the case), GNC kept one group, to
// the trajectory's last stretch, and the run verification, which weighed
// a run's fall of chi2 against its size times the plain c^2, could never
// reject anything there: 213 m off with either solver. Measured against
// the data's own scale (4 times the 99th percentile of the kept loop
// closures' deleted-residual statistics, or GNC's tightened threshold),
// deleting that run lowers chi2 by 0.89 against 0.30, and it goes.
TEST(Gnc, AWrongRunIsWeighedAtTheDataScale) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/3d/parking-garage.g2o");
  CAIRN_REQUIRE_DATASET(path);
  const auto r = ExpectExactRejection(ReadAliased(path, 923, 10, 1492), true, "gn");
  EXPECT_GE(r.verified, 10);
}

// smallGrid3D with 9 wrong loop closures in aliased groups of 5 (the
// table's seed for its 5% case): GNC rejected three of one group and kept
// the fourth, 29-122, which the small grid bends to for less than c^2
// (0.018 m off, 8 of 9 rejected), with either solver; with groups of 10 at
// 10%, Ceres kept two of a group the same way (0.27 m). A member whose run
// is mostly rejected goes with it.
TEST(Gnc, AMemberOfARejectedRunGoesWithIt) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/3d/smallGrid3D.g2o");
  CAIRN_REQUIRE_DATASET(path);
  struct Case {
    int count, size;
    uint64_t seed;
  };
  // The last two: two or one of a group of five kept while three or four
  // were rejected (robustness-seeds.sh, smallGrid3D, 10% in groups of 5,
  // seeds 4 and 12).
  for (const Case& c :
       {Case{9, 5, 1185}, Case{17, 10, 1191}, Case{17, 5, 1185}, Case{17, 5, 1193}}) {
    const AliasedFile f = ReadAliased(path, c.count, c.size, c.seed);
    for (bool gn : {false, true})
      ExpectExactRejection(f, gn, "seed " + std::to_string(c.seed) + (gn ? " gn" : " ceres"));
  }
}

// manhattan with 98 wrong loop closures in aliased groups of 10 (the
// table's case at SEED=7): the single verification rejected a good loop
// closure, 88-231, while a wrong run was still kept and bent its stretch;
// the run went next, but the verdict on 88-231 stood, and the result ended
// 0.28 m off. When a run goes, the verdicts on single loop closures are
// withdrawn and re-admission weighs them again.
TEST(Gnc, ARunRejectedWithdrawsTheVerdictsItBent) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/2d/manhattan.g2o");
  CAIRN_REQUIRE_DATASET(path);
  ExpectExactRejection(ReadAliased(path, 98, 10, 1002), true, "gn");
}

// MIT with 4 wrong loop closures in one aliased group (the table's 20% case
// in groups of 5 at SEED=7): GNC kept the group, which agrees with nothing
// but itself, and rejected the 4 good loop closures it contradicts, each
// far over c^2 against the bent graph; deleting the group alone released
// too little, and the result ended 198 m off. The swap test takes the
// strained group out and the 4 back: the truncated cost falls 199 -> 133.
TEST(Gnc, AStrainedRunIsSwappedForWhatItContradicts) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/2d/MIT.g2o");
  CAIRN_REQUIRE_DATASET(path);
  const AliasedFile f = ReadAliased(path, 4, 5, 389, InitMethod::kChordal);
  for (bool gn : {false, true}) ExpectExactRejection(f, gn, gn ? "gn" : "ceres");
}

// MIT's 20 loop closures with a wrong pair (seed 402) and a wrong group of
// 4 (seed 393), the robustness table's SEED=11 cases: the wrong ones are
// strained too little for the verification's runs (a pair's fall of chi2,
// 10, against 0.5 x 2 x c^2 = 22.8), and GNC kept them with 7 and 4 good
// ones rejected (165 m and 190 m off). With few loop closures, every kept
// one is a swap candidate.
TEST(Gnc, WithFewLoopClosuresAnyKeptRunIsSwappedOnTrial) {
  CAIRN_LONG_NUMERICAL_TEST();
  const std::string path = testing::DatasetPath("g2o/2d/MIT.g2o");
  CAIRN_REQUIRE_DATASET(path);
  for (const auto& [count, size, seed] : {std::tuple{2, 10, 402}, std::tuple{4, 5, 393}}) {
    const AliasedFile f = ReadAliased(path, count, size, seed, InitMethod::kChordal);
    for (bool gn : {false, true})
      ExpectExactRejection(f, gn, "seed " + std::to_string(seed) + (gn ? " gn" : " ceres"));
  }
}

TEST(Gnc, NinetyPercentRandomWrongLoopClosures) {
  CAIRN_LONG_NUMERICAL_TEST();
  // As many wrong loop closures as 0.9 times the good ones... and 9 times.
  for (uint64_t seed : {31, 32}) {
    const Simulation sim = Simulated(2, 500, seed);
    PoseGraph reference = sim.noisy;
    SolveWithCeres(reference, CeresOptions());
    const size_t good = sim.noisy.CountEdges(EdgeKind::kLoopClosure);
    for (double times : {0.9, 9.0}) {
      PoseGraph corrupted = sim.noisy;
      const auto added =
          AddWrongLoopClosures(corrupted, static_cast<int>(times * good), seed);
      const std::set<VertexPair> wrong(added.begin(), added.end());
      for (bool gn : {false, true}) {
        PoseGraph g = corrupted;
        const auto r = SolveRejectingOutliers(g, Solver(gn));
        size_t caught = 0;
        for (const auto& p : r.rejected) caught += wrong.count(p);
        const std::string what = "seed " + std::to_string(seed) + " x" +
                                 std::to_string(times) + (gn ? " gn" : " ceres");
        EXPECT_GE(caught, 0.95 * wrong.size()) << what;
        EXPECT_LE(r.rejected.size() - caught, 0.05 * good) << what;
        EXPECT_LT(Rms(g, reference), 0.05) << what;
      }
    }
  }
}

std::set<VertexPair> PairsOf(const PoseGraph& g) {
  std::set<VertexPair> out;
  for (const Edge& e : g.edges())
    if (e.kind == EdgeKind::kLoopClosure) out.emplace(e.from, e.to);
  return out;
}

TEST(Cli, GroupedCorruptionThenTheKeptGraphWritten) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(testing::TempDir()) / "grouped";
  fs::create_directories(dir);
  const std::string tool = CAIRN_TOOL, d = dir.string();
  int status = 0;
  testing::RunCommand(tool + " simulate -o " + d + "/clean.g2o --truth " + d +
                          "/truth.g2o --poses 400 --seed 3 2>&1",
                      &status);
  ASSERT_EQ(status, 0);
  const std::string out = testing::RunCommand(
      tool + " corrupt " + d + "/clean.g2o -o " + d + "/bad.g2o --outliers 12 --grouped 5 " +
          "--truth " + d + "/truth.g2o --seed 2 2>&1",
      &status);
  ASSERT_EQ(status, 0) << out;
  const PoseGraph clean = ReadGraph(d + "/clean.g2o"), bad = ReadGraph(d + "/bad.g2o");
  EXPECT_EQ(bad.CountEdges(EdgeKind::kLoopClosure), clean.CountEdges(EdgeKind::kLoopClosure) + 12);
  const std::string run = testing::RunCommand(
      tool + " optimize " + d + "/bad.g2o -o " + d + "/out.g2o --reject-outliers --rejected " +
          d + "/rejected.g2o --report " + d + "/r.json 2>&1",
      &status);
  ASSERT_EQ(status, 0) << run;
  // -o holds exactly the kept loop closures, --rejected the others.
  const PoseGraph kept = ReadGraph(d + "/out.g2o"), rejected = ReadGraph(d + "/rejected.g2o");
  const std::set<VertexPair> all = PairsOf(bad), in = PairsOf(kept), out_pairs = PairsOf(rejected);
  EXPECT_EQ(in.size() + out_pairs.size(), all.size());
  for (const VertexPair& p : out_pairs) EXPECT_EQ(in.count(p), 0u);
  for (const VertexPair& p : in) EXPECT_EQ(all.count(p), 1u);
  EXPECT_EQ(kept.CountEdges(EdgeKind::kOdometry), bad.CountEdges(EdgeKind::kOdometry));
  std::ifstream list(d + "/bad.g2o.outliers.txt");
  std::string line;
  size_t wrong = 0, caught = 0;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    int64_t a, b;
    ss >> a >> b;
    ++wrong;
    caught += out_pairs.count({a, b});
  }
  EXPECT_EQ(wrong, 12u);
  EXPECT_EQ(caught, 12u);
  // The report is the whole run's: the input's chi2 and the written graph's.
  std::ifstream rf(d + "/r.json");
  const std::string json((std::istreambuf_iterator<char>(rf)), std::istreambuf_iterator<char>());
  auto number = [&](const std::string& key) {
    const size_t at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? NAN : std::stod(json.substr(at + key.size() + 4));
  };
  EXPECT_NEAR(number("final_chi2"), Chi2(kept), 1e-6 * Chi2(kept));
  EXPECT_NEAR(number("initial_chi2"), Chi2(bad), 1e-6 * Chi2(bad));
  EXPECT_GT(number("iterations"), 5);
  EXPECT_EQ(number("input_loop_closures"), static_cast<double>(all.size()));
  // --rejected is checked with the other outputs, before any work.
  testing::RunCommand(tool + " optimize " + d + "/bad.g2o -o " + d + "/o2.g2o --reject-outliers " +
                          "--rejected " + d + "/nodir/r.g2o 2>&1",
                      &status);
  EXPECT_NE(status, 0);
  EXPECT_FALSE(fs::exists(d + "/o2.g2o"));
  testing::RunCommand(tool + " optimize " + d + "/bad.g2o -o " + d + "/o2.g2o --rejected " + d +
                          "/r2.g2o 2>&1",
                      &status);
  EXPECT_EQ(status, 2);  // --rejected without --reject-outliers
}

}  // namespace
}  // namespace cairn
