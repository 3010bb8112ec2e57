#include "cairn/robust/outliers.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>

#include "cairn/graph/chi2.h"
#include "cairn/graph/initialization.h"
#include "cairn/robust/leverage.h"
#include "cairn/robust/pairwise_consistency.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"

namespace cairn {

double ChiSquaredQuantile(double p, int dof) {
  if (!(p > 0 && p < 1) || dof < 1) throw std::invalid_argument("ChiSquaredQuantile: bad arguments");
  // The survival function in closed form for an integer dof: a Poisson sum
  // (even dof), erfc and a half-integer series (odd dof).
  auto survival = [dof](double x) {
    const double h = x / 2;
    double sum = 0, term;
    if (dof % 2 == 0) {
      term = std::exp(-h);
      for (int i = 0; i < dof / 2; ++i) {
        sum += term;
        term *= h / (i + 1);
      }
      return sum;
    }
    sum = std::erfc(std::sqrt(h));
    term = std::exp(-h) * std::sqrt(h) / (std::sqrt(M_PI) / 2);  // h^(1/2) e^-h / Gamma(3/2)
    for (int i = 0; i < (dof - 1) / 2; ++i) {
      sum += term;
      term *= h / (i + 1.5);
    }
    return sum;
  };
  // The survival function falls from 1: bisect for survival(x) = 1 - p.
  double lo = 0, hi = dof + 10.0;
  while (survival(hi) > 1 - p) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = (lo + hi) / 2;
    (survival(mid) > 1 - p ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

double LoopClosureThreshold(double confidence, int dof, size_t loop_closures) {
  if (!(confidence > 0 && confidence < 1))
    throw std::invalid_argument("the confidence must lie in (0, 1)");
  const double n = static_cast<double>(std::max<size_t>(loop_closures, 1));
  return ChiSquaredQuantile(1 - (1 - confidence) / n, dof);
}

namespace {

// A mu at which GNC's weights are binary for any residual but those within
// a millionth of the threshold.
constexpr double kBinaryMu = 1e6;

// What the stages of SolveRejectingOutliers share. Until the verdict: the
// loop closures' weights and residuals at the working estimate. After it:
// which edges are out, and the graph without them.
struct RejectionState {
  RejectionState(const PoseGraph& g, const GraphSolver& s, const OutlierRejectionOptions& o)
      : graph(g), solve(s), options(o), work(g), inliers(g.dimension()) {}

  const PoseGraph& graph;
  const GraphSolver& solve;
  const OutlierRejectionOptions& options;
  OutlierRejectionResult out;
  double c2 = 0;                 // the truncation threshold
  // GNC's: c2 times the consistent set's variance factor (at most 1).
  double gnc_c2 = 0;
  double cycle_variance = 1;  // the pairwise stage's variance factor
  std::vector<bool> trusted;  // per edge of `graph`: consistent, and a neighbour agrees
  std::vector<size_t> closures;  // edges of `graph` that are loop closures
  PoseGraph work;                // its vertices hold the current estimate
  std::vector<double> w, r2;     // per loop closure: GNC's weight, chi2 at `work`
  // Per edge of `graph`: rejected, rejected by the verification (never
  // taken back by re-admission), and with a whole run (not even when it fits).
  std::vector<bool> rejected, verified_out, run_out;
  PoseGraph inliers;  // `graph` without the rejected edges
  std::vector<size_t> kept;    // edges of `inliers` that are loop closures
  std::vector<size_t> origin;  // per edge of `inliers`, its index in `graph`
  // Runs (their edges in `graph`, ascending) that passed a verification at
  // the data's scale (RunThreshold).
  std::set<std::vector<size_t>> runs_passed;
  // The last deleted-residual statistic the verification found for each run
  // it tested (same key): the swap test's candidates.
  std::map<std::vector<size_t>, double> run_gain;
  // Swap trials left for FewClosureCandidates, over the whole run.
  int few_swaps_left = 8;

  // Every inner solve goes through here, so the result covers the run.
  SolveResult Solve(PoseGraph& g, const InnerSolve& limits = {}) {
    SolveResult r = solve(g, limits);
    ++out.rounds;
    out.iterations += r.iterations;
    out.solve_time_s += r.time_s;
    return r;
  }
};

// The weighted problem at the working estimate: weights scale the loop
// closures' information; a loop closure at weight 0, or outside the current
// stage, is left out altogether (a negligible weight would still cost fill
// in the factorisation: random wrong loop closures join far-apart poses).
PoseGraph WeightedGraph(const RejectionState& s, const std::vector<bool>& in) {
  PoseGraph g(s.graph.dimension());
  for (const Vertex& v : s.work.vertices()) g.AddVertex(v.id, v.x, v.fixed);
  size_t next = 0;  // the next loop closure, in edge order
  for (size_t k = 0; k < s.graph.edges().size(); ++k) {
    Edge e = s.graph.edges()[k];
    if (next < s.closures.size() && s.closures[next] == k) {
      const size_t i = next++;
      if (!in[i] || !(s.w[i] > 0)) continue;
      e.information *= std::max(s.w[i], 1e-9);
    }
    g.AddEdge(e);
  }
  return g;
}

void KeepEstimate(RejectionState& s, const PoseGraph& g) {
  for (size_t v = 0; v < g.vertices().size(); ++v) s.work.vertices()[v].x = g.vertices()[v].x;
}

// The weighted problem solved from the working estimate.
SolveResult SolveWeighted(RejectionState& s, const std::vector<bool>& in, const InnerSolve& limits) {
  PoseGraph g = WeightedGraph(s, in);
  const SolveResult r = s.Solve(g, limits);
  KeepEstimate(s, g);
  return r;
}

// A fresh start (`init`) of the weighted problem as the working estimate.
void InitializeOn(RejectionState& s, const std::vector<bool>& in, InitMethod init) {
  PoseGraph g = WeightedGraph(s, in);
  Initialize(g, init);
  KeepEstimate(s, g);
}

// Unweighted, at the working estimate.
std::vector<double> Residuals(const RejectionState& s) {
  std::vector<double> r2(s.closures.size());
  for (size_t i = 0; i < s.closures.size(); ++i)
    r2[i] = EdgeChi2(s.work, s.graph.edges()[s.closures[i]]);
  return r2;
}

// The least mu at which every residual in `in` below `hi` (those that weigh
// in) lies inside the surrogate's convex part: Yang et al.'s start, with
// nothing to spare. When they all fit, a mu at which the weights are binary.
double ConvexMu(const RejectionState& s, const std::vector<bool>& in, double hi) {
  double r2_max = 0;
  for (size_t i = 0; i < s.closures.size(); ++i)
    if (in[i] && std::isfinite(s.r2[i]) && s.r2[i] < hi) r2_max = std::max(r2_max, s.r2[i]);
  const double c2 = s.gnc_c2;
  return r2_max > c2 ? c2 / (2 * r2_max - c2) : kBinaryMu;
}

// GNC over the loop closures in `in`, from mu (<= 0: where every residual is
// inside the surrogate's convex part). With `fit_mu`, no round's mu lies
// below the convex start of the residuals that weigh in.
void Gnc(RejectionState& s, const std::vector<bool>& in, double mu, const char* stage,
         bool fit_mu = false) {
  const OutlierRejectionOptions& options = s.options;
  const double c2 = s.gnc_c2;
  std::vector<double>& w = s.w;
  const std::vector<double>& r2 = s.r2;
  const double convex = ConvexMu(s, in, std::numeric_limits<double>::infinity());
  if (convex == kBinaryMu) {
    // Every residual within the threshold: the estimate is already a
    // minimum of the truncated cost, and every weight is 1 at any mu.
    for (size_t i = 0; i < s.closures.size(); ++i)
      if (in[i]) w[i] = 1;
    if (options.verbose) std::fprintf(stderr, "gnc (%s): every loop closure fits\n", stage);
    return;
  }
  if (mu <= 0) mu = convex;
  size_t count = 0;
  for (bool x : in) count += x;
  std::vector<double> solved_w;
  for (int round = 0; round < options.max_rounds; ++round) {
    if (fit_mu) mu = std::max(mu, ConvexMu(s, in, (mu + 1) / mu * c2));
    const double lo = mu / (mu + 1) * c2, hi = (mu + 1) / mu * c2;
    double undecided = 0;
    size_t active = 0;
    for (size_t i = 0; i < s.closures.size(); ++i) {
      if (!in[i]) continue;
      if (!std::isfinite(r2[i]) || r2[i] >= hi) w[i] = 0;
      else if (r2[i] <= lo) w[i] = 1;
      else w[i] = std::sqrt(c2 / r2[i] * mu * (mu + 1)) - mu;
      undecided += w[i] * (1 - w[i]);
      active += w[i] > 0;
    }
    // Binary weights that the last solve has not changed: the surrogate
    // has become the truncated cost.
    if (round > 0 && undecided < 1e-6 * std::max<size_t>(1, count) && mu > 1) break;
    // The weights of the last solve again: its estimate is their optimum
    // already (intel's rounds on the consistent set), so only mu moves on.
    if (round > 0 && w == solved_w) {
      mu *= options.mu_factor;
      continue;
    }
    solved_w = w;
    s.out.solve =
        SolveWeighted(s, in, InnerSolve{options.inner_iterations, options.inner_tolerance});
    s.r2 = Residuals(s);
    if (options.verbose)
      std::fprintf(stderr,
                   "gnc (%s) round %d: mu %.3g, %zu of %zu loop closures weighed in, "
                   "sum w(1-w) %.3g, chi2 %.6g, %d iterations, %.2f s\n",
                   stage, round + 1, mu, active, count, undecided, s.out.solve.final_chi2,
                   s.out.solve.iterations, s.out.solve.time_s);
    mu *= options.mu_factor;
  }
}

// Pairwise consistency: of the largest set of loop closures no two of which
// close an inconsistent cycle with the odometry, those a neighbour agrees
// with (none when the stage is off).
std::vector<bool> ConfirmedByConsistency(RejectionState& s, size_t* n_confirmed) {
  std::vector<bool> confirmed(s.closures.size(), false);
  *n_confirmed = 0;
  if (s.options.consistency_window <= 0 || s.closures.empty()) return confirmed;
  const auto start = std::chrono::steady_clock::now();
  ConsistentSetOptions o;
  o.threshold_chi2 = s.c2;
  o.window = s.options.consistency_window;
  o.reach = 10 * o.window;
  o.partners = s.options.consistency_partners;
  o.threads = s.options.threads;
  o.scale_by_variance = s.options.scale_by_variance;
  const ConsistentSet set = MaximumConsistentSet(s.graph, o);
  size_t n_in = 0;
  s.cycle_variance = set.variance_factor;
  for (size_t i = 0; i < confirmed.size(); ++i) {
    n_in += set.in[i];
    confirmed[i] = set.in[i] && set.supported[i];
    *n_confirmed += confirmed[i];
  }
  if (s.options.verbose)
    std::fprintf(stderr,
                 "pairwise consistency: %zu of %zu loop closures mutually consistent (%s; %zu "
                 "pairs tested, %zu inconsistent beyond %.4g, variance factor %.3g), %zu of "
                 "them agreeing with a neighbour, %.2f s\n",
                 n_in, s.closures.size(), set.exact ? "exact" : "greedy",
                 set.tested_pairs, set.conflicts, s.c2 * set.variance_factor,
                 set.variance_factor, *n_confirmed,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return confirmed;
}

// The noise the consistent set's least-squares solution shows, chi2 per
// degree of freedom, never above 1. Information matrices far looser than the
// noise (intel's, city10000's) let a wrong loop closure bend the estimate
// into place within c^2; GNC's threshold is tightened by as much.
double ConsistentVarianceFactor(const RejectionState& s, size_t n_confirmed) {
  const std::vector<bool> held = HeldConstant(s.graph);
  size_t edges = n_confirmed;
  for (const Edge& e : s.graph.edges()) edges += e.kind != EdgeKind::kLoopClosure;
  const double d = s.graph.TangentSize();
  const double dof =
      d * (static_cast<double>(edges) -
           static_cast<double>(held.size() - std::count(held.begin(), held.end(), true)));
  return dof > 0 ? std::clamp(s.out.solve.final_chi2 / dof, 1e-6, 1.0) : 1.0;
}

// GNC's mu on the trusted loop closures, after their least squares: a
// residual beyond restart_chi2_factor times the plain threshold weighs 0
// from the start, not beyond that factor times GNC's tightened one. That
// least squares is capped, so its estimate can still be bent, and how far
// a good loop closure sits from a bent estimate is the bend's, whatever
// the noise: with the tightened threshold (sphere2500's variance factor is
// 0.03), 1,056 of 2,491 trusted loop closures at chi2 12 and up weighed 0
// from the first round and never came back, and the kept graph, held by too
// few, settled in another basin (Gauss-Newton, 20% aliased in groups of 10:
// 78 m off). Widening only until 90% of the trusted ones were within reach
// was tried: parking-garage (variance factor 0.001) has 90% within the
// tight reach and still ends 47-208 m off with 20% aliased in groups of 5,
// exact with this reach. Over all loop closures the start is this stage's
// result, and the tightened reach stays: there it keeps the random wrong
// ones, by the thousand, out of every solve.
// (gnc_c2 <= c2, the variance factors being at most 1, and the factor
// exceeds 1: the reach lies beyond GNC's threshold, mu is positive.)
double TrustedRestartMu(const RejectionState& s) {
  const double reach = s.options.restart_chi2_factor * s.c2;
  return s.gnc_c2 / (reach - s.gnc_c2);
}

// The confirmed loop closures a fresh start can hold. The start is made on
// them; those beyond a reach leave, and it is made again on the rest. While
// the set repeats, the reach shrinks, from GNC's restart reach
// (restart_chi2_factor c^2) down to kScreenFloor times GNC's threshold; it
// ends when the set repeats there, or after kScreenRounds starts. (Down to
// GNC's threshold itself, a start, which is no optimum, puts the tail of good
// loop closures out: three on sphere2500 with random wrong ones, whose GNC
// rounds then took 47 iterations instead of 29.) An aliased group that the
// pairwise tests confirmed bends a start made with it, and least squares
// from there spends tens of iterations bending the graph further to it,
// and GNC as many unbending it (sphere2500, 20% aliased in groups of 10:
// 208 iterations, 13.8 s, in the least squares and GNC's first three
// rounds). Each start without the worst of them moves away from the rest:
// on city10000's 20% in groups of 10, the 66 wrong ones' least chi2 goes
// 3.8 -> 12,000 in nine starts, while the good ones' 99th percentile falls
// 151 -> 0.13. A good loop closure screened out is weighed by GNC all the
// same. Only starts that the loop closures shape are screened (chordal,
// auto).
std::vector<bool> ScreenedStart(RejectionState& s, const std::vector<bool>& confirmed) {
  constexpr int kScreenRounds = 12;
  constexpr double kScreenFloor = 4;
  std::vector<bool> in = confirmed;
  const InitMethod init = s.options.fresh_init;
  if (init != InitMethod::kChordal && init != InitMethod::kAuto) {
    if (init != InitMethod::kFile) InitializeOn(s, in, init);
    return in;
  }
  double reach = s.options.restart_chi2_factor * s.c2;
  const double least = kScreenFloor * s.gnc_c2;
  std::vector<bool> next(confirmed.size());
  const auto screen = [&] {
    for (size_t i = 0; i < next.size(); ++i) next[i] = confirmed[i] && s.r2[i] <= reach;
  };
  for (int round = 0; round < kScreenRounds; ++round) {
    InitializeOn(s, in, init);
    s.r2 = Residuals(s);
    screen();
    while (next == in && reach > least) {
      reach = std::max(least, reach / 4);
      screen();
    }
    if (next == in) break;
    in = next;
  }
  return in;
}

// The consistent loop closures first, alone: least squares from a fresh
// start on those of them it holds (ScreenedStart; GNC's convex start from a
// poor estimate, e.g. odometry, can settle in a wrong basin), then GNC on
// all of them from there in case a wrong one was confirmed. Their estimate
// is one the other wrong loop closures have not bent. Then all loop
// closures, from that estimate: mu starts where residuals beyond
// restart_chi2_factor c^2 weigh 0.
void GncFromConfirmed(RejectionState& s, const std::vector<bool>& confirmed, size_t n_confirmed) {
  const double restart = 1 / (s.options.restart_chi2_factor - 1);
  // From a fresh start on the trusted loop closures alone, capped: the few
  // wrong ones left among them (aliased groups the pairwise tests could not
  // tell: 11 of 534 on city10000) make least squares slow (chi2 140,000
  // after 100 iterations), and GNC on them, with the threshold scaled by the
  // variance factor the short cycles showed, cuts them out instead.
  if (s.options.scale_by_variance) s.gnc_c2 = s.c2 * s.cycle_variance;
  const std::vector<bool> screened = ScreenedStart(s, confirmed);
  s.out.solve = SolveWeighted(s, screened, InnerSolve{s.options.trusted_iterations, 0});
  s.r2 = Residuals(s);
  if (s.options.verbose)
    std::fprintf(stderr,
                 "least squares on %zu of the %zu confirmed (those a fresh start holds): chi2 "
                 "%.6g, %d iterations, %.2f s; GNC's threshold %.4g\n",
                 static_cast<size_t>(std::count(screened.begin(), screened.end(), true)),
                 n_confirmed, s.out.solve.final_chi2, s.out.solve.iterations, s.out.solve.time_s,
                 s.gnc_c2);
  // A least squares that converged within the cap is one no aliased group
  // bent (they make it slow: in the robustness table every cell whose
  // trusted set holds a group hits the cap, no other does). There the wide
  // reach's small mu adds nothing but rounds (5-6 of 12-17, on the heavy
  // tail of good loop closures); from a bent estimate its more even weights
  // are what unbend it (smallGrid3D's aliased cases: 3 of 120 cells over
  // twelve seeds failed more with the convex start there).
  Gnc(s, confirmed, TrustedRestartMu(s), "confirmed", s.out.solve.converged);
  // The rest by the noise of that solution.
  size_t n_in = 0;
  for (size_t i = 0; i < s.closures.size(); ++i) n_in += confirmed[i] && s.w[i] >= 0.5;
  if (s.options.scale_by_variance) {
    s.gnc_c2 = s.c2 * ConsistentVarianceFactor(s, n_in);
    if (s.options.verbose)
      std::fprintf(stderr, "GNC's threshold from the %zu kept: %.4g\n", n_in, s.gnc_c2);
  }
  // Again (options.gnc_passes) while the set of loop closures that weigh in
  // changes: as the estimate improves, good loop closures that did not fit
  // come within reach (a region that only they constrain can relax towards
  // them). Re-admission and the take-back of what fits, after the
  // verification, bring those back too, at a fraction of a pass's cost.
  const std::vector<bool> all(s.closures.size(), true);
  // Before the first pass: those within its reach, so that a pass that ends
  // keeping just them is not repeated.
  std::vector<bool> in_before(s.closures.size());
  for (size_t i = 0; i < s.closures.size(); ++i)
    in_before[i] = s.r2[i] < s.options.restart_chi2_factor * s.gnc_c2;
  for (int pass = 0; pass < s.options.gnc_passes; ++pass) {
    Gnc(s, all, restart, "all");
    std::vector<bool> in(s.closures.size());
    for (size_t i = 0; i < s.closures.size(); ++i) in[i] = s.w[i] >= 0.5 || s.r2[i] <= s.gnc_c2;
    if (in == in_before) break;
    in_before = in;
  }
}

// The graph without the rejected loop closures, at the working estimate.
void BuildInliers(RejectionState& s) {
  PoseGraph g(s.graph.dimension());
  for (const Vertex& v : s.work.vertices()) g.AddVertex(v.id, v.x, v.fixed);
  s.kept.clear();
  s.origin.clear();
  for (size_t k = 0; k < s.graph.edges().size(); ++k) {
    if (s.rejected[k]) continue;
    if (s.graph.edges()[k].kind == EdgeKind::kLoopClosure) s.kept.push_back(g.edges().size());
    s.origin.push_back(k);
    g.AddEdge(s.graph.edges()[k]);
  }
  s.inliers = std::move(g);
}

// After the set of rejected edges changed: the inliers again, from the last
// inliers' estimate, solved to convergence.
void SolveInliersAgain(RejectionState& s) {
  for (Vertex& v : s.work.vertices()) v.x = s.inliers.vertex(v.id).x;
  BuildInliers(s);
  s.out.solve = s.Solve(s.inliers);
}

// Of the groups of kept loop closures (edges of s.inliers; `gain`, the fall
// of chi2 when each goes) whose deletion lowers chi2 by more than their
// size times `c2`, the one whose deletion releases most in the rest of the
// graph (the fall beyond its own residuals): good loop closures near a bend
// have large residuals too, the wrong one holds it. groups.size() when
// there is none.
size_t WorstToDelete(const RejectionState& s, const std::vector<std::vector<size_t>>& groups,
                     const std::vector<double>& gain, double c2) {
  size_t worst = groups.size();
  double worst_release = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (!(gain[g] > static_cast<double>(groups[g].size()) * c2)) continue;
    double release = gain[g];
    for (size_t k : groups[g]) release -= EdgeChi2(s.inliers, s.inliers.edges()[k]);
    if (worst == groups.size() || release > worst_release) {
      worst = g;
      worst_release = release;
    }
  }
  return worst;
}

// Released from a bend, loop closures GNC rejected may fit again: those
// come back (not those the verification rejected). Returns how many.
size_t TakeBackFitting(RejectionState& s) {
  size_t readmitted = 0;
  for (size_t k = 0; k < s.graph.edges().size(); ++k)
    if (s.rejected[k] && !s.verified_out[k] && EdgeChi2(s.inliers, s.graph.edges()[k]) <= s.c2) {
      s.rejected[k] = false;
      ++readmitted;
    }
  return readmitted;
}

// The kept loop closures' ends (lower id first) and their order by them.
void KeptEnds(const RejectionState& s, std::vector<std::pair<int64_t, int64_t>>* ends,
              std::vector<size_t>* order) {
  const size_t n = s.kept.size();
  ends->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Edge& e = s.inliers.edges()[s.kept[i]];
    (*ends)[i] = {std::min(e.from, e.to), std::max(e.from, e.to)};
  }
  order->resize(n);
  std::iota(order->begin(), order->end(), 0);
  std::sort(order->begin(), order->end(),
            [&](size_t a, size_t b) { return (*ends)[a] < (*ends)[b]; });
}

// Runs of kept loop closures, two or more long, as indices into s.kept: a
// loop closure joins another's run when both its ends lie within
// group_window ids of the other's (a place seen again from consecutive
// poses; aliasing produces such runs too).
std::vector<std::vector<size_t>> KeptRuns(const RejectionState& s,
                                          const std::vector<std::pair<int64_t, int64_t>>& ends,
                                          const std::vector<size_t>& order) {
  const int64_t w = s.options.group_window;
  const size_t n = ends.size();
  std::vector<size_t> root(n);
  std::iota(root.begin(), root.end(), 0);
  auto find = [&root](size_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (size_t a = 0; a < n; ++a)
    for (size_t b = a + 1; b < n && ends[order[b]].first - ends[order[a]].first <= w; ++b)
      if (std::abs(ends[order[b]].second - ends[order[a]].second) <= w)
        root[find(order[a])] = find(order[b]);
  std::vector<std::vector<size_t>> by_root(n), runs;
  for (size_t i : order) by_root[find(i)].push_back(i);  // each run in id order
  for (std::vector<size_t>& r : by_root)
    if (r.size() >= 2) runs.push_back(std::move(r));
  return runs;
}

// Whether a kept loop closure outside `run` joins the same two stretches
// (both ends within `window` ids of a member's): the two then close a
// short cycle, which the pairwise stage and GNC have tested already. A
// wrong run that GNC keeps is the only link between its stretches.
bool HasParallel(const std::vector<size_t>& run,
                 const std::vector<std::pair<int64_t, int64_t>>& ends,
                 const std::vector<size_t>& order, int64_t window) {
  std::vector<size_t> members(run);
  std::sort(members.begin(), members.end());
  for (size_t i : run) {
    auto it = std::lower_bound(order.begin(), order.end(), ends[i].first - window,
                               [&](size_t k, int64_t lo) { return ends[k].first < lo; });
    for (; it != order.end() && ends[*it].first <= ends[i].first + window; ++it)
      if (std::abs(ends[*it].second - ends[i].second) <= window &&
          !std::binary_search(members.begin(), members.end(), *it))
        return true;
  }
  return false;
}

// The verification rejects these edges of s.inliers (`whole_run`: as a
// run), then the rest is re-solved, and loop closures GNC rejected that fit
// again are taken back. Runs are tested after single loop closures, whose
// statistics a wrong run bent while it stayed: when a run goes, the verdicts
// on single ones are withdrawn, and they are candidates of re-admission
// again (manhattan, aliased 5% in groups of 10, SEED=7: 88-231, chi2 3.5,
// went for a fall of 35.7 against 32.2 while a wrong run 489-2983 was
// kept, and the result ended 0.28 m off).
void RejectVerified(RejectionState& s, const std::vector<size_t>& edges, bool whole_run) {
  if (whole_run)
    for (size_t g = 0; g < s.graph.edges().size(); ++g)
      if (s.verified_out[g] && !s.run_out[g]) {
        s.verified_out[g] = false;
        --s.out.verified;
      }
  for (size_t k : edges) {
    const size_t g = s.origin[k];
    s.rejected[g] = s.verified_out[g] = true;
    if (whole_run) s.run_out[g] = true;
    ++s.out.verified;
  }
  SolveInliersAgain(s);
  const size_t readmitted = TakeBackFitting(s);
  if (readmitted > 0) {
    if (s.options.verbose)
      std::fprintf(stderr, "verify: %zu rejected loop closures fit again: kept\n", readmitted);
    SolveInliersAgain(s);
  }
}

// The runs worth testing, as edges of s.inliers: those without a parallel
// one, in pieces of at most kMaxRun (a corridor revisited end to end links
// hundreds; the statistic's cost grows as the cube of the size), short
// enough to qualify (the fall of chi2 cannot exceed chi2 itself).
std::vector<std::vector<size_t>> RunsToTest(const RejectionState& s, double c2) {
  constexpr size_t kMaxRun = 64;
  const double chi2 = Chi2(s.inliers);
  std::vector<std::pair<int64_t, int64_t>> ends;
  std::vector<size_t> order;
  KeptEnds(s, &ends, &order);
  std::vector<std::vector<size_t>> runs;
  for (const std::vector<size_t>& r : KeptRuns(s, ends, order)) {
    if (HasParallel(r, ends, order, s.options.consistency_window)) continue;
    for (size_t at = 0; at < r.size(); at += kMaxRun) {
      std::vector<size_t> piece;
      for (size_t i = at; i < std::min(r.size(), at + kMaxRun); ++i) piece.push_back(s.kept[r[i]]);
      if (piece.size() >= 2 && static_cast<double>(piece.size()) * c2 < chi2)
        runs.push_back(std::move(piece));
    }
  }
  return runs;
}

// A run (edges of s.inliers) as runs_passed and run_gain know it: its edges
// in `graph`, ascending, which stay the same while s.inliers is rebuilt.
std::vector<size_t> RunKey(const RejectionState& s, const std::vector<size_t>& run) {
  std::vector<size_t> k;
  for (size_t e : run) k.push_back(s.origin[e]);
  std::sort(k.begin(), k.end());
  return k;
}

// The run verification, when no single loop closure is worth deleting: of
// the runs whose deletion lowers chi2 by more than their size times `c2`
// (RunThreshold; the truncated cost is then lower without them), the one
// that releases most beyond its own residuals goes whole. Returns whether
// one did.
//
// At the data's scale (`c2` under c^2) nearly every run qualifies
// (parking-garage: 112, 2 s a verification), and the verification comes
// again after each pass of re-admission, which moves the estimate little:
// a run that passed keeps its verdict while its members stay the same.
bool RejectWorstRun(RejectionState& s, double c2) {
  if (s.options.group_window <= 0) return false;
  std::vector<std::vector<size_t>> edges = RunsToTest(s, c2);
  const bool remember = c2 < s.c2;
  const auto key = [&s](const std::vector<size_t>& run) { return RunKey(s, run); };
  if (remember)
    edges.erase(std::remove_if(edges.begin(), edges.end(),
                               [&](const std::vector<size_t>& r) {
                                 return s.runs_passed.count(key(r)) > 0;
                               }),
                edges.end());
  if (edges.empty()) return false;
  const std::vector<double> gain = GroupDeletedResidualChi2(s.inliers, edges);
  for (size_t r = 0; r < edges.size(); ++r) s.run_gain[key(edges[r])] = gain[r];
  if (remember)
    for (size_t r = 0; r < edges.size(); ++r)
      if (!(gain[r] > static_cast<double>(edges[r].size()) * c2))
        s.runs_passed.insert(key(edges[r]));
  const size_t worst = WorstToDelete(s, edges, gain, c2);
  if (worst == edges.size()) {
    if (s.options.verbose) {
      double most = 0;
      for (size_t r = 0; r < edges.size(); ++r)
        if (std::isfinite(gain[r]))
          most = std::max(most, gain[r] / (static_cast<double>(edges[r].size()) * c2));
      std::fprintf(stderr,
                   "verify: %zu runs tested, none beyond its threshold (at most %.3g of it)\n",
                   edges.size(), most);
    }
    return false;
  }
  if (s.options.verbose) {
    const Edge& e = s.inliers.edges()[edges[worst].front()];
    std::fprintf(stderr,
                 "verify: the run of %zu loop closures from %lld-%lld: deleting it lowers chi2 "
                 "by %.4g > %zu x %.4g: rejected\n",
                 edges[worst].size(), static_cast<long long>(e.from),
                 static_cast<long long>(e.to), gain[worst], edges[worst].size(), c2);
  }
  RejectVerified(s, edges[worst], true);
  return true;
}

double RunThreshold(const RejectionState& s, const std::vector<double>& stats);

// Verification. GNC's weights are decided one loop closure at a time, at
// the estimate: a wrong loop closure that the trajectory has bent to fit
// looks like a good one there. Deleting it would release that bend, and the
// deleted-residual statistic predicts by how much chi2 falls: more than c^2
// and the truncated cost itself is lower without it (it then costs c^2).
// The worst such loop closure goes, the rest is re-solved and checked again.
// Returns the kept loop closures' statistics at the estimate it leaves when
// it ended on them (nothing left to reject), else nothing.
std::vector<double> Verify(RejectionState& s) {
  const OutlierRejectionOptions& options = s.options;
  for (int round = 0; options.verify && round < options.max_verify_rounds; ++round) {
    if (!s.out.solve.usable) break;
    std::vector<double> gain;
    try {
      gain = DeletedResidualChi2(s.inliers, s.kept);
    } catch (const std::runtime_error& e) {
      if (options.verbose) std::fprintf(stderr, "verification skipped: %s\n", e.what());
      return {};
    }
    std::vector<std::vector<size_t>> singles;
    for (size_t k : s.kept) singles.push_back({k});
    const size_t worst = WorstToDelete(s, singles, gain, s.c2);
    if (worst == singles.size()) {
      bool rejected_run = false;
      try {
        rejected_run = RejectWorstRun(s, RunThreshold(s, gain));
      } catch (const std::runtime_error& e) {
        if (options.verbose) std::fprintf(stderr, "run verification skipped: %s\n", e.what());
      }
      if (!rejected_run) return gain;
      continue;
    }
    const Edge& e = s.inliers.edges()[s.kept[worst]];
    if (options.verbose)
      std::fprintf(stderr,
                   "verify: loop closure %lld-%lld fits (chi2 %.3g) but deleting it lowers chi2 "
                   "by %.4g > %.4g: rejected\n",
                   static_cast<long long>(e.from), static_cast<long long>(e.to),
                   EdgeChi2(s.inliers, e), gain[worst], s.c2);
    RejectVerified(s, singles[worst], false);
  }
  return {};
}

// The noise the kept graph shows, chi2 per degree of freedom (the
// a-posteriori variance factor), never above 1: when the information
// matrices are looser than the residuals (intel's are, by two orders of
// magnitude), a loop closure to a loosely held part of the graph can be bent
// into place within c^2 whether it is right or not.
double VarianceFactor(const RejectionState& s) {
  const PoseGraph& inliers = s.inliers;
  const std::vector<bool> held = HeldConstant(inliers);
  const double variables =
      s.graph.TangentSize() * static_cast<double>(
          inliers.vertices().size() - std::count(held.begin(), held.end(), true));
  const double dof = s.graph.TangentSize() * static_cast<double>(inliers.edges().size()) - variables;
  return dof > 0 ? std::min(1.0, Chi2(inliers) / dof) : 1.0;
}

// What a good loop closure costs on these data: readmit_tail times the
// 99th percentile of the kept loop closures' own deleted-residual
// statistics, never beyond c^2 (past it the truncated cost is lower without
// the loop closure); 0 when they cannot be computed. Re-admission takes the
// larger of this and c^2 times the variance factor. The factor is a mean
// and assumes chi2's tail: good loop closures are often heavier-tailed (at
// the clean optima, the ratio of that percentile to the median is 20 on
// intel and 18 on manhattan, chi2(3)'s is 4.8), and the factor's bound
// alone kept out good ones whose innovation was 19-33 on manhattan (bound
// 18, wrong ones 169 and more) and 1.6 on intel (bound 0.40-0.44, wrong
// ones 2.07 and more). `stats`: those statistics at the current estimate
// when the verification left them (else they are computed here).
double TailBound(const RejectionState& s, std::vector<double> stats) {
  if (stats.empty()) {
    try {
      stats = DeletedResidualChi2(s.inliers, s.kept);
    } catch (const std::runtime_error&) {
      return 0;
    }
  }
  std::vector<double> own;
  for (double d : stats)
    if (std::isfinite(d)) own.push_back(d);
  if (own.empty()) return 0;
  const size_t at = std::min(own.size() - 1, static_cast<size_t>(0.99 * own.size()));
  std::nth_element(own.begin(), own.begin() + at, own.end());
  return std::min(s.c2, s.options.readmit_tail * own[at]);
}

// What a run's fall of chi2 is weighed against, per loop closure in it: the
// plain c^2 where that can act. Where the kept graph's whole chi2 is under
// two of them, no run could ever fall by its size times c^2: the
// information is far looser than the residuals (parking-garage: variance
// factor 0.0003, chi2 under 10 against a c^2 of 42), and a wrong run bent
// into place stays, whatever it bends (213 m there). Such graphs are
// weighed at the data's own scale: GNC's tightened threshold, or the tail
// of the kept loop closures' own statistics (TailBound) when higher, so
// that good runs in a heavy tail stay. Not on every graph: on sphere2500
// (chi2 727) the runs that scale admits cost 7 s and changed nothing.
// `stats`: the kept loop closures' deleted-residual statistics.
double RunThreshold(const RejectionState& s, const std::vector<double>& stats) {
  if (!(Chi2(s.inliers) < 2 * s.c2)) return s.c2;
  return std::max(s.gnc_c2, TailBound(s, stats));
}

// Of the rejected loop closures `cand` (edges of s.graph), those whose
// innovation statistic (the rise of the optimal chi2 were each added alone)
// is within `bound` are taken back. Returns how many; 0 also when the
// statistic cannot be computed. `report` names the stage in the lines that
// --verbose prints, one a candidate (none when null).
size_t TakeBackWithin(RejectionState& s, const std::vector<size_t>& cand, double bound,
                      const char* report) {
  std::vector<Edge> edges;
  for (size_t k : cand) edges.push_back(s.graph.edges()[k]);
  std::vector<InnovationStat> stat;
  try {
    stat = InnovationChi2(s.inliers, edges, bound);
  } catch (const std::runtime_error& e) {
    if (report) std::fprintf(stderr, "%s skipped: %s\n", report, e.what());
    return 0;
  }
  size_t back = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    const bool ok = stat[i].chi2 <= bound;
    if (report)
      std::fprintf(stderr, "readmit? %lld-%lld chi2 %.4g innovation %s%.4g spread %.4g%s\n",
                   static_cast<long long>(edges[i].from), static_cast<long long>(edges[i].to),
                   EdgeChi2(s.inliers, edges[i]), stat[i].exact ? "" : "at least ", stat[i].chi2,
                   stat[i].spread, ok ? " yes" : "");
    if (ok) {
      s.rejected[cand[i]] = false;
      ++back;
    }
  }
  return back;
}

// One pass of re-admission: the rejected loop closures (not rejected by the
// verification, chi2 within readmit_reach c^2) whose innovation statistic is
// within the larger of c^2 times the variance factor and `tail` (TailBound)
// are taken back. Returns how many; 0 also when there is no candidate or
// the statistic cannot be computed.
size_t Readmit(RejectionState& s, double tail) {
  const OutlierRejectionOptions& options = s.options;
  std::vector<size_t> cand;
  for (size_t k = 0; k < s.graph.edges().size(); ++k)
    if (s.rejected[k] && !s.verified_out[k] &&
        EdgeChi2(s.inliers, s.graph.edges()[k]) <= options.readmit_reach * s.c2)
      cand.push_back(k);
  if (cand.empty()) return 0;
  const double factor = VarianceFactor(s);
  const double bound = std::max(tail, s.c2 * factor);
  const size_t back = TakeBackWithin(s, cand, bound, options.verbose ? "re-admission" : nullptr);
  if (options.verbose)
    std::fprintf(stderr, "re-admission: %zu of %zu candidates within %.4g (variance factor %.3g)\n",
                 back, cand.size(), bound, factor);
  return back;
}

// Re-admission until a pass takes none back, each pass followed by a solve
// and the verification.
void ReadmitPasses(RejectionState& s, double tail) {
  for (int pass = 0; s.options.readmit && pass < s.options.max_passes; ++pass) {
    if (!s.out.solve.usable) break;
    if (Readmit(s, tail) == 0) break;
    SolveInliersAgain(s);
    Verify(s);
  }
}

// A kept loop closure whose run GNC mostly rejected goes with it, for good
// (never taken back). Its run: the loop closures with both ends within
// group_window ids of its own that agree with it (their cycle passes the
// pairwise test); it goes when at least two of those are rejected and they
// outnumber the kept ones (itself counted), and so on while some go (two of
// a group of five kept, three rejected: SEED=4, smallGrid3D, 10% in groups
// of 5, 29-122 and 30-123 kept, 0.062 m off, when the rejected had to be
// twice the kept). Aliasing
// produces runs, and GNC weighs their members one at a time, so the member
// the graph bends to most cheaply can stay while the rest of its run is out
// (smallGrid3D, 5% in aliased groups of 5: 29-122 kept, 26-119 to 28-121
// rejected, 0.018 m off). Without the agreement, proximity alone took good
// loop closures next to rejected wrong ones (intel, city10000, manhattan:
// 1-3 a case). Returns how many went.
size_t RejectWithTheirRun(RejectionState& s) {
  const int64_t w = s.options.group_window;
  if (w <= 0 || s.closures.empty()) return 0;
  const CycleTester cycles(s.graph);
  if (cycles.size() != s.closures.size()) return 0;
  const double agree = s.c2 * s.cycle_variance;
  std::vector<size_t> by_lo(s.closures.size());
  std::iota(by_lo.begin(), by_lo.end(), 0);
  std::sort(by_lo.begin(), by_lo.end(),
            [&](size_t a, size_t b) { return cycles.Ends(a) < cycles.Ends(b); });
  std::vector<size_t> out;
  for (size_t i = 0; i < s.closures.size(); ++i) {
    if (s.rejected[s.closures[i]]) continue;
    const auto [lo, hi] = cycles.Ends(i);
    size_t near_rejected = 0, near_kept = 1;
    auto it = std::lower_bound(by_lo.begin(), by_lo.end(), lo - w,
                               [&](size_t j, int64_t v) { return cycles.Ends(j).first < v; });
    for (; it != by_lo.end() && cycles.Ends(*it).first <= lo + w; ++it) {
      const size_t j = *it;
      if (j == i || std::abs(cycles.Ends(j).second - hi) > w ||
          !(cycles.PairChi2(i, j) <= agree))
        continue;
      ++(s.rejected[s.closures[j]] ? near_rejected : near_kept);
    }
    if (near_rejected >= 2 && near_rejected > near_kept) out.push_back(s.closures[i]);
  }
  for (size_t k : out) {
    s.rejected[k] = s.run_out[k] = true;
    if (s.options.verbose)
      std::fprintf(stderr, "with its run: %lld-%lld rejected\n",
                   static_cast<long long>(s.graph.edges()[k].from),
                   static_cast<long long>(s.graph.edges()[k].to));
  }
  return out.size();
}

// A loop closure that fits the kept graph's solution is never rejected: every
// rejected one within c^2 there comes back if it was trusted (pairwise
// consistent, a neighbour agreeing), within GNC's threshold (c^2 times the
// variance factor) if not, and the kept graph is re-solved, a few passes
// (taking some back moves the estimate). Intel's good loop closures are
// noisier than its information says, in a heavier tail than chi2's: the
// tightened threshold alone dropped 15 of the clean file's (chi2 up to 0.62
// at the optimum, against 0.26). Not the plain c^2 for all: a wrong loop
// closure to intel's dangling end, which only odometry holds, fits within
// it, and taken back bent that end by 2 m; it has no neighbour to agree.
// Nor a run the verification rejected whole: its members each fit, alone,
// a graph that bends easily, and together they would bend it again.
void TakeBackAllFitting(RejectionState& s) {
  for (int pass = 0; pass < s.options.max_passes && s.out.solve.usable; ++pass) {
    size_t back = 0;
    for (size_t k = 0; k < s.graph.edges().size(); ++k)
      if (s.rejected[k] && !s.run_out[k] &&
          EdgeChi2(s.inliers, s.graph.edges()[k]) <= (s.trusted[k] ? s.c2 : s.gnc_c2)) {
        s.rejected[k] = false;
        ++back;
      }
    if (back == 0) break;
    if (s.options.verbose)
      std::fprintf(stderr, "%zu rejected loop closures fit the kept graph's solution: kept\n",
                   back);
    SolveInliersAgain(s);
  }
}

bool SolveKeptToOptimum(RejectionState& s, const PoseGraph& start);

// The truncated cost the rejection minimises, at `at`'s vertices: every
// edge's chi2, a loop closure's at most c^2 (a rejected one costs c^2 unless
// it fits).
double TruncatedCost(const RejectionState& s, const PoseGraph& at) {
  double cost = 0;
  for (const Edge& e : s.graph.edges()) {
    const double chi2 = EdgeChi2(at, e);
    cost += e.kind == EdgeKind::kLoopClosure ? std::min(chi2, s.c2) : chi2;
  }
  return cost;
}

// The rejected loop closures (not those rejected with their run) whose
// addition would raise the optimal chi2 by at most c^2: under the truncated
// cost each is cheaper in than out. They come back together; returns how
// many.
size_t AdmitWithinTruncation(RejectionState& s) {
  std::vector<size_t> cand;
  for (size_t k = 0; k < s.graph.edges().size(); ++k)
    if (s.rejected[k] && !s.run_out[k]) cand.push_back(k);
  return cand.empty() ? 0 : TakeBackWithin(s, cand, s.c2, nullptr);
}

// The runs (edges of s.inliers) that the verification last weighed at more
// than half their size times c^2, the most strained per loop closure first,
// at most `most`. Weighing every run again here cost sphere2500 4 s.
std::vector<std::vector<size_t>> StrainedRuns(const RejectionState& s, size_t most) {
  constexpr double kStrain = 0.5;
  std::vector<std::pair<double, std::vector<size_t>>> strained;
  for (std::vector<size_t>& run : RunsToTest(s, 0)) {
    const auto found = s.run_gain.find(RunKey(s, run));
    const double size = static_cast<double>(run.size());
    if (found != s.run_gain.end() && found->second > kStrain * size * s.c2)
      strained.emplace_back(found->second / size, std::move(run));
  }
  std::stable_sort(strained.begin(), strained.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::vector<size_t>> runs;
  for (size_t i = 0; i < std::min(most, strained.size()); ++i) runs.push_back(strained[i].second);
  return runs;
}

// One swap on trial: `t` (a copy of the state) without `run`, solved from its
// estimate and from a fresh start (the estimate is the run's bend), with the
// rejected loop closures that are cheaper in than out taken back. Returns
// how many came back; t.inliers then holds the solution.
size_t TrySwap(RejectionState& t, const std::vector<size_t>& run) {
  for (size_t k : run) {
    const size_t g = t.origin[k];
    t.rejected[g] = t.verified_out[g] = t.run_out[g] = true;
  }
  BuildInliers(t);
  SolveKeptToOptimum(t, t.graph);
  const size_t back = t.out.solve.usable ? AdmitWithinTruncation(t) : 0;
  if (back > 0) SolveInliersAgain(t);
  return back;
}

// Whether swapping `run` (edges of s.inliers) out lowers the truncated cost
// from `cost`; if it does, the swap is made. The trial's solves count either
// way.
bool SwapIfCheaper(RejectionState& s, const std::vector<size_t>& run, double cost) {
  RejectionState t = s;
  const size_t back = TrySwap(t, run);
  const double swapped = t.out.solve.usable ? TruncatedCost(t, t.inliers) : cost;
  const bool take = back > 0 && swapped < (1 - 1e-9) * cost;
  if (s.options.verbose) {
    const Edge& e = s.inliers.edges()[run.front()];
    std::fprintf(stderr,
                 "swap: the run of %zu from %lld-%lld out, %zu rejected back: truncated cost "
                 "%.6g -> %.6g: %s\n",
                 run.size(), static_cast<long long>(e.from), static_cast<long long>(e.to), back,
                 cost, swapped, take ? "swapped" : "kept");
  }
  if (!take) {
    s.out.rounds = t.out.rounds;
    s.out.iterations = t.out.iterations;
    s.out.solve_time_s = t.out.solve_time_s;
    return false;
  }
  t.out.verified += run.size();
  // A single loop closure swapped out may come back later, when cheaper in
  // (AdmitWithinTruncation after the swaps); a run stays out whole.
  if (run.size() == 1) t.run_out[s.origin[run.front()]] = false;
  s.rejected = std::move(t.rejected);
  s.verified_out = std::move(t.verified_out);
  s.run_out = std::move(t.run_out);
  s.inliers = std::move(t.inliers);
  s.kept = std::move(t.kept);
  s.origin = std::move(t.origin);
  s.work = std::move(t.work);
  s.out = std::move(t.out);
  return true;
}

// Whether the kept graph's information is about as tight as its noise
// (variance factor at least 0.1), so that c^2 means what it says. With
// looser information (intel's, city10000's: 0.013-0.016) c^2 is generous
// and the truncated cost itself can prefer a wrong loop closure in (intel,
// 50% random: one swapped in for a good one, 0.5 m off).
bool RealisticInformation(const RejectionState& s) { return VarianceFactor(s) >= 0.1; }

// Where loop closures are few (a graph that revisits each place once or
// twice, as MIT's 20), every kept run and single loop closure is a swap
// candidate, the most strained first (deleted-residual statistic per loop
// closure): a wrong one held in place costs little there, while the good
// ones it contradicts each cost more than c^2 against its bend (MIT,
// aliased 10% in groups of 10, SEED=11: a wrong pair kept at a strain of 5
// per loop closure, 7 good rejected, 165 m off). Only with realistic
// information (RealisticInformation).
std::vector<std::vector<size_t>> FewClosureCandidates(const RejectionState& s) {
  constexpr size_t kFewClosures = 60;
  if (s.closures.size() > kFewClosures || !RealisticInformation(s)) return {};
  std::vector<std::pair<int64_t, int64_t>> ends;
  std::vector<size_t> order;
  KeptEnds(s, &ends, &order);
  std::vector<std::vector<size_t>> runs;
  std::vector<bool> in_run(s.kept.size(), false);
  for (const std::vector<size_t>& r : KeptRuns(s, ends, order)) {
    runs.emplace_back();
    for (size_t k : r) {
      in_run[k] = true;
      runs.back().push_back(s.kept[k]);
    }
  }
  for (size_t k = 0; k < s.kept.size(); ++k)
    if (!in_run[k]) runs.push_back({s.kept[k]});
  if (runs.empty()) return {};
  std::vector<double> gain;
  try {
    gain = GroupDeletedResidualChi2(s.inliers, runs);
  } catch (const std::runtime_error&) {
    return {};
  }
  std::vector<std::pair<double, size_t>> strain;
  for (size_t r = 0; r < runs.size(); ++r)
    if (std::isfinite(gain[r]))
      strain.emplace_back(-gain[r] / static_cast<double>(runs[r].size()), r);
  std::stable_sort(strain.begin(), strain.end());
  std::vector<std::vector<size_t>> out;
  for (const auto& entry : strain) out.push_back(std::move(runs[entry.second]));
  return out;
}

// The swap test. GNC can end in a local minimum of the truncated cost where a
// wrong run is kept and the good loop closures it contradicts are rejected:
// each alone costs more than c^2 against the bent graph, and deleting the run
// alone releases less than its size times c^2 (MIT, aliased 20% in groups of
// 5, SEED=7: 4 wrong kept, 4 good rejected, 198 m off, truncated cost 199
// against the clean answer's 133). So a strained run (then, where loop
// closures are few, any kept one: FewClosureCandidates) is swapped out on
// trial, and the swap stays when the whole truncated cost falls; the run is
// then rejected whole. Returns whether one was.
bool SwapStrainedRun(RejectionState& s) {
  constexpr size_t kMaxTries = 3;
  if (s.options.group_window <= 0 || !s.out.solve.usable) return false;
  if (std::find(s.rejected.begin(), s.rejected.end(), true) == s.rejected.end()) return false;
  const double cost = TruncatedCost(s, s.inliers);
  std::set<std::vector<size_t>> tried;
  for (const std::vector<size_t>& run : StrainedRuns(s, kMaxTries)) {
    tried.insert(RunKey(s, run));
    if (SwapIfCheaper(s, run, cost)) return true;
  }
  if (s.few_swaps_left <= 0) return false;
  for (const std::vector<size_t>& run : FewClosureCandidates(s)) {
    if (!tried.insert(RunKey(s, run)).second) continue;
    if (s.few_swaps_left-- <= 0) break;
    if (SwapIfCheaper(s, run, cost)) return true;
  }
  return false;
}

// The kept graph to its optimum. The estimate the stages leave may sit in
// another basin than the kept graph's own optimum (it was shaped by the loop
// closures weighed in along the way): it is solved in full from there and
// from a fresh start (options.fresh_init on the kept graph; kFile: the
// starting estimate), and the lower chi2 stays. Returns whether the fresh
// start's did.
bool SolveKeptToOptimum(RejectionState& s, const PoseGraph& start) {
  PoseGraph fresh = s.inliers;
  for (size_t i = 0; i < fresh.vertices().size(); ++i)
    fresh.vertices()[i].x = start.vertices()[i].x;
  if (s.options.fresh_init != InitMethod::kFile) Initialize(fresh, s.options.fresh_init);
  const SolveResult here = s.Solve(s.inliers);
  const SolveResult anew = s.Solve(fresh);
  const bool take_fresh = anew.usable && (!here.usable || anew.final_chi2 < here.final_chi2);
  if (s.options.verbose)
    std::fprintf(stderr,
                 "kept graph in full: chi2 %.10g from the estimate (%d iterations), %.10g from "
                 "a fresh %s start (%d iterations): %s\n",
                 here.final_chi2, here.iterations, anew.final_chi2, ToString(s.options.fresh_init),
                 anew.iterations, take_fresh ? "fresh" : "estimate");
  s.out.solve = take_fresh ? anew : here;
  if (take_fresh) s.inliers = std::move(fresh);
  return take_fresh;
}

// GNC until its weights are binary, from the confirmed loop closures when
// there are some. The verdict: a loop closure stays if its weight is up or
// it now fits.
void RunGnc(RejectionState& s) {
  size_t n_confirmed = 0;
  const std::vector<bool> confirmed = ConfirmedByConsistency(s, &n_confirmed);
  s.trusted.assign(s.graph.edges().size(), false);
  for (size_t i = 0; i < s.closures.size(); ++i) s.trusted[s.closures[i]] = confirmed[i];
  if (n_confirmed > 0) {
    GncFromConfirmed(s, confirmed, n_confirmed);
  } else {
    Gnc(s, std::vector<bool>(s.closures.size(), true), 0, "all");
  }
  s.rejected.assign(s.graph.edges().size(), false);
  s.verified_out.assign(s.graph.edges().size(), false);
  s.run_out.assign(s.graph.edges().size(), false);
  for (size_t i = 0; i < s.closures.size(); ++i)
    if (s.w[i] < 0.5 && !(s.r2[i] <= s.gnc_c2)) s.rejected[s.closures[i]] = true;
}

// The swap test, pass after pass while it swaps, then re-admission on the
// kept graph it leaves.
void SwapPasses(RejectionState& s, double tail) {
  bool swapped = false;
  for (int pass = 0; pass < s.options.max_passes && SwapStrainedRun(s); ++pass) {
    swapped = true;
    TakeBackAllFitting(s);
  }
  // A swap moves the kept graph to another basin: what re-admission could
  // not take before may fit now, a single loop closure swapped out on the
  // way among them (MIT, 90% random, SEED=13: the good 241-235 went in the
  // first swap, for two rejected ones; it stayed out, 4.6 m off, until it
  // was allowed back, and came back when the next swap took a wrong one
  // out). Where c^2 means what it says, all that is cheaper in than out.
  if (swapped && RealisticInformation(s)) {
    const size_t back = AdmitWithinTruncation(s);
    if (s.options.verbose)
      std::fprintf(stderr, "after the swaps: %zu rejected loop closures cheaper in than out\n",
                   back);
    if (back > 0) SolveInliersAgain(s);
  } else if (swapped) {
    ReadmitPasses(s, tail);
  }
}

}  // namespace

OutlierRejectionResult SolveRejectingOutliers(PoseGraph& graph, const GraphSolver& solve,
                                              const OutlierRejectionOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  // Its working graphs are rebuilt from poses and between-edges.
  RequireNoLandmarks(graph, "outlier rejection");
  const double initial_chi2 = Chi2(graph);
  RejectionState s(graph, solve, options);
  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (graph.edges()[k].kind == EdgeKind::kLoopClosure) s.closures.push_back(k);
  s.c2 = options.threshold_chi2 > 0
             ? options.threshold_chi2
             : LoopClosureThreshold(options.confidence, graph.TangentSize(), s.closures.size());
  s.out.threshold_chi2 = s.c2;
  s.gnc_c2 = s.c2;
  s.w.assign(s.closures.size(), 1.0);
  s.r2 = Residuals(s);

  RunGnc(s);
  BuildInliers(s);  // at GNC's estimate
  s.out.solve = s.Solve(s.inliers);
  if (options.verbose)
    std::fprintf(stderr, "without the %zu rejected: chi2 %.6g, %d iterations, %.2f s\n",
                 s.closures.size() - s.kept.size(), s.out.solve.final_chi2,
                 s.out.solve.iterations, s.out.solve.time_s);
  // GNC's estimate far from the kept graph's own optimum (its solve took
  // many iterations) sits in a basin the weights shaped: a fresh start is
  // tried now, before the verification spends its re-solves there
  // (sphere2500, 20% aliased in groups of 10: 16 rejections one at a time,
  // 72 s, before the last stage's fresh start found the clean optimum).
  if (options.final_solve && options.fresh_check_iterations > 0 &&
      s.out.solve.iterations >= options.fresh_check_iterations && SolveKeptToOptimum(s, graph))
    TakeBackAllFitting(s);
  std::vector<double> kept_stats = Verify(s);

  // Re-admission. A good loop closure outside the consistent set that the
  // estimate of the consistent ones left beyond GNC's reach stays out
  // above; at the final estimate, the innovation statistic
  // r^T (I + J Sigma J^T)^{-1} r (the rise of the optimal chi2 if it were
  // added, Sigma the exact joint covariance of its poses) tells whether the
  // graph could take it. Those within the bound come back, the rest is
  // re-solved and verified again. The tail bound is fixed at the first
  // pass: the percentile grows with each good loop closure taken back, and
  // a wrong one to a loosely held stretch would follow (intel, 90% random:
  // innovation 2.07, bound 1.1 then 2.1).
  const double tail =
      options.readmit && s.out.solve.usable ? TailBound(s, std::move(kept_stats)) : 0;
  ReadmitPasses(s, tail);

  size_t with_run = 0;
  for (size_t went = 1; went > 0; with_run += went) went = RejectWithTheirRun(s);
  if (with_run > 0) SolveInliersAgain(s);
  TakeBackAllFitting(s);
  SwapPasses(s, tail);
  // A fresh start can land the kept graph in another basin, where rejected
  // loop closures that the stages' estimate could not take fit again.
  if (options.final_solve && SolveKeptToOptimum(s, graph)) TakeBackAllFitting(s);

  OutlierRejectionResult out = std::move(s.out);
  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (s.rejected[k]) {
      out.rejected.emplace_back(graph.edges()[k].from, graph.edges()[k].to);
      out.rejected_edges.push_back(k);
    }
  auto& dst = graph.vertices();
  for (size_t i = 0; i < dst.size(); ++i) dst[i].x = s.inliers.vertices()[i].x;
  // The run's: the input's chi2 (every edge, at the start) and the kept
  // graph's at the end.
  out.solve.initial_chi2 = initial_chi2;
  out.solve.final_chi2 = Chi2(s.inliers);
  return out;
}

PoseGraph WithoutEdges(const PoseGraph& graph, const std::vector<size_t>& edges) {
  PoseGraph out = graph;
  std::vector<bool> keep(graph.edges().size(), true);
  for (size_t k : edges) keep.at(k) = false;
  out.KeepEdges(keep);
  return out;
}

}  // namespace cairn
