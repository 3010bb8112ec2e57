// Incremental re-optimisation against a cold solve, on a simulated
// 10,000-pose graph: the cold solve builds the problem and optimises from
// odometry; the re-optimisation adds one pose with its odometry (and a loop
// closure) to an optimised graph and optimises again, warm-started, with the
// problem kept (Gauss-Newton: its symbolic analysis extended, or redone).
// BM_Step: the cost of one step against the graph's size (10,000 and
// 100,000 poses): partial updates (Update) against re-solving it all with
// Gauss-Newton or Ceres (Optimize).
//   build/bench/bench_incremental
// Args: dimension, solver (0 Ceres, 1 Gauss-Newton), then for the warm
// case: add a loop closure (0/1), extend the Gauss-Newton analysis (1) or
// redo it with a fresh ordering at every solve (0). BM_Step: dimension,
// poses, mode (0 Ceres, 1 Gauss-Newton whole, 2 partial updates), loop
// closure (0/1).
#include <benchmark/benchmark.h>

#include <limits>
#include <map>
#include <memory>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/incremental.h"
#include "cairn/graph/simulate.h"

namespace cairn {
namespace {

constexpr int kPoses = 10000;
constexpr int kExtra = 2000;  // poses the warm benchmark may add

const Simulation& Sim(int dimension, int poses = kPoses) {
  static std::map<std::pair<int, int>, std::unique_ptr<Simulation>> sims;
  auto& sim = sims[{dimension, poses}];
  if (!sim) {
    SimulationOptions o;
    o.dimension = dimension;
    o.poses = poses + kExtra;
    o.nodes_per_lap = 100;
    o.seed = 1;
    sim = std::make_unique<Simulation>(Simulate(o));
  }
  return *sim;
}

// The first `n` poses of the simulation and the edges among them, the
// estimate chained from odometry as the simulator leaves it.
PoseGraph Prefix(const PoseGraph& g, int64_t n) {
  PoseGraph out(g.dimension());
  for (const Vertex& v : g.vertices())
    if (v.id < n) out.AddVertex(v.id, v.x, v.fixed);
  for (const Edge& e : g.edges())
    if (e.from < n && (e.IsPrior() || e.to < n)) out.AddEdge(e);
  return out;
}

IncrementalOptions Options() {
  IncrementalOptions o;
  o.ceres.threads = 2;
  o.gauss_newton.threads = 2;
  return o;
}

void BM_ColdSolve(benchmark::State& state) {
  const int dim = static_cast<int>(state.range(0));
  const bool gn = state.range(1) == 1;
  const PoseGraph start = Prefix(Sim(dim).noisy, kPoses);
  const IncrementalOptions o = Options();
  double iterations = 0, chi2 = 0;
  for (auto _ : state) {
    state.PauseTiming();
    PoseGraph g = start;
    state.ResumeTiming();
    const SolveResult r = gn ? SolveGaussNewton(g, o.gauss_newton) : SolveWithCeres(g, o.ceres);
    iterations += r.iterations;
    chi2 = r.final_chi2;
  }
  state.counters["iterations"] = iterations / state.iterations();
  state.counters["chi2"] = chi2;
}

// The true pose nearest to pose i among those at least 20 steps older: where
// a place recognizer would close a loop.
int64_t NearestOlder(const PoseGraph& truth, int64_t i) {
  const auto t = [&](int64_t id) -> Eigen::Vector3d {
    const PoseParams& x = truth.vertex(id).x;
    return {x[0], x[1], truth.dimension() == 3 ? x[2] : 0.0};
  };
  int64_t best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (int64_t j = 0; j + 20 < i; ++j) {
    const double d = (t(j) - t(i)).squaredNorm();
    if (d < best_d) best_d = d, best = j;
  }
  return best;
}

// The odometry edge into pose i: looked up by the caller (a scan of every
// edge would be timed, and at 100,000 poses cost more than the update).
const Edge* OdometryInto(const Simulation& sim, int64_t i) {
  for (const Edge& e : sim.noisy.edges())
    if (e.kind == EdgeKind::kOdometry && e.to == i) return &e;
  return nullptr;
}

template <typename Pose>
void AddOnePose(IncrementalOptimizer& opt, const Simulation& sim, int64_t i, int64_t loop_to,
                const Edge* odometry) {
  Pose z;
  if constexpr (std::is_same_v<Pose, SE2>) z = ToSE2(odometry->z); else z = ToSE3(odometry->z);
  opt.AddPose(i, ToPose<Pose>(opt.graph().vertex(i - 1).x) * z);
  opt.AddEdge(*odometry);
  if (loop_to < 0) return;
  // A loop closure measured exactly (from the truth), so that it pulls
  // against the drift the odometry accumulated.
  const int64_t j = loop_to;
  Edge lc = *odometry;
  lc.kind = EdgeKind::kLoopClosure;
  lc.from = j;
  lc.to = i;
  lc.z = ToParams(
      ToPose<Pose>(sim.truth.vertex(j).x).Between(ToPose<Pose>(sim.truth.vertex(i).x)));
  opt.AddEdge(lc);
}

void BM_AddPoseAndReoptimize(benchmark::State& state) {
  const int dim = static_cast<int>(state.range(0));
  const SolverKind solver = state.range(1) == 1 ? SolverKind::kGaussNewton : SolverKind::kCeres;
  const bool loop = state.range(2) == 1;
  IncrementalOptions o = Options();
  // 0: every re-optimisation computes a fresh AMD ordering.
  if (state.range(3) == 0) o.reorder_growth = -1;
  const Simulation& sim = Sim(dim);
  IncrementalOptimizer opt(Prefix(sim.noisy, kPoses), o);
  opt.Optimize(solver);
  int64_t next = kPoses;
  double iterations = 0, setup = 0;
  for (auto _ : state) {
    if (next >= kPoses + kExtra) {
      state.SkipWithError("out of simulated poses");
      break;
    }
    state.PauseTiming();
    // Finding the loop partner is the front-end's job: not timed.
    const int64_t loop_to = loop ? NearestOlder(sim.truth, next) : -1;
    const Edge* odometry = OdometryInto(sim, next);
    state.ResumeTiming();
    if (dim == 2) {
      AddOnePose<SE2>(opt, sim, next, loop_to, odometry);
    } else {
      AddOnePose<SE3>(opt, sim, next, loop_to, odometry);
    }
    const SolveResult r = opt.Optimize(solver);
    iterations += r.iterations;
    setup += r.setup_time_s;
    ++next;
  }
  state.counters["iterations"] = iterations / state.iterations();
  state.counters["setup_ms"] = 1e3 * setup / state.iterations();
  state.counters["poses"] = static_cast<double>(opt.graph().vertices().size());
  state.counters["reorderings"] = opt.gauss_newton_reorderings();
  state.counters["extensions"] = opt.gauss_newton_extensions();
}

// One step on a graph of range(1) poses (the simulated measurements),
// optimised and (partial updates)
// factorised before the timing starts: a pose, its odometry and (range(3))
// a loop closure to the nearest older place, then Update or Optimize.
// Fresh factorisations (reserved room used up, fill bound passed) happen
// inside the timed steps, as they would on a robot, and are counted.
void BM_Step(benchmark::State& state) {
  const int dim = static_cast<int>(state.range(0));
  const int poses = static_cast<int>(state.range(1));
  const int mode = static_cast<int>(state.range(2));
  const bool loop = state.range(3) == 1;
  const Simulation& sim = Sim(dim, poses);
  // Optimised from the truth: from the chained odometry of 100,000 poses
  // (chi2 1e12) the cold solve stops short of the optimum, and the steps
  // would then be timed carrying its remainder.
  IncrementalOptimizer opt(Prefix(sim.truth, poses), Options());
  opt.Optimize(SolverKind::kGaussNewton);
  if (mode == 2) opt.Update();
  int64_t next = poses;
  int refactorized = 0, solved = 0;
  for (auto _ : state) {
    if (next >= poses + kExtra) {
      state.SkipWithError("out of simulated poses");
      break;
    }
    state.PauseTiming();
    const int64_t loop_to = loop ? NearestOlder(sim.truth, next) : -1;
    const Edge* odometry = OdometryInto(sim, next);
    state.ResumeTiming();
    if (dim == 2) {
      AddOnePose<SE2>(opt, sim, next, loop_to, odometry);
    } else {
      AddOnePose<SE3>(opt, sim, next, loop_to, odometry);
    }
    if (mode == 2) {
      const UpdateResult u = opt.Update();
      refactorized += u.refactorized;
      solved += u.solved_unknowns;
    } else {
      opt.Optimize(mode == 1 ? SolverKind::kGaussNewton : SolverKind::kCeres);
    }
    ++next;
  }
  state.counters["refactorized"] = refactorized;
  state.counters["solved"] = static_cast<double>(solved) / state.iterations();
}

BENCHMARK(BM_Step)
    ->Args({2, 10000, 2, 0})->Args({2, 10000, 2, 1})
    ->Args({2, 100000, 2, 0})->Args({2, 100000, 2, 1})
    ->Args({3, 10000, 2, 0})->Args({3, 10000, 2, 1})
    ->Iterations(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step)
    ->Args({2, 10000, 1, 0})->Args({2, 10000, 1, 1})->Args({2, 10000, 0, 0})->Args({2, 10000, 0, 1})
    ->Args({2, 100000, 1, 0})->Args({2, 100000, 1, 1})->Args({2, 100000, 0, 0})
    ->Args({2, 100000, 0, 1})
    ->Iterations(5)->Unit(benchmark::kMillisecond);

BENCHMARK(BM_ColdSolve)->Args({2, 0})->Args({2, 1})->Args({3, 0})->Args({3, 1})
    ->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AddPoseAndReoptimize)
    ->Args({2, 0, 0, 1})->Args({2, 0, 1, 1})
    ->Args({2, 1, 0, 1})->Args({2, 1, 1, 1})->Args({2, 1, 1, 0})
    ->Args({3, 0, 0, 1})->Args({3, 0, 1, 1})
    ->Args({3, 1, 0, 1})->Args({3, 1, 1, 1})->Args({3, 1, 1, 0})
    ->Iterations(20)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cairn

BENCHMARK_MAIN();
