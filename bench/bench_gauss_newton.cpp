// The Gauss-Newton path's hot spots on a generated 10,000-pose graph:
// linearise-and-accumulate (Jacobians from the autodiff factors, H and b
// assembled block by block) and the numeric factorisation with its solve.
//   build/bench/bench_gauss_newton --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "cairn/solvers/gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/graph/simulate.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
namespace {

// A graph and its problem, built once per benchmark: simulated, or a shared
// dataset file when `file` is given.
struct Fixture {
  Fixture(int dimension, CholeskyKind kind, int threads, const std::string& file = "")
      : sim(file.empty() ? Make(dimension) : Simulation{ReadGraph(file), PoseGraph(2), {}}) {
    PoseGraph& g = sim.noisy;
    manifold = g.dimension() == 2 ? factors::MakeSE2Manifold() : factors::MakeSE3Manifold();
    const auto held = HeldConstant(g);
    for (size_t i = 0; i < g.vertices().size(); ++i) {
      problem.AddParameterBlock(g.vertices()[i].x.data(), g.ParameterSize(), manifold.get());
      if (held[i]) problem.SetParameterBlockConstant(g.vertices()[i].x.data());
    }
    for (const Edge& e : g.edges()) {
      std::vector<double*> blocks{g.vertex(e.from).x.data()};
      if (!e.IsPrior()) blocks.push_back(g.vertex(e.to).x.data());
      problem.AddResidualBlock(MakeCostFunction(g, e), nullptr, blocks);
    }
    GaussNewtonOptions o;
    o.linear_solver = kind;
    o.threads = threads;
    problem.Prepare(o);
  }
  static Simulation Make(int dimension) {
    SimulationOptions o;
    o.dimension = dimension;
    o.poses = 10000;
    o.nodes_per_lap = 100;
    o.seed = 1;
    return Simulate(o);
  }
  Simulation sim;
  std::unique_ptr<ceres::Manifold> manifold;
  GaussNewtonProblem problem;
};

void BM_Linearize(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)), CholeskyKind::kSupernodal,
            static_cast<int>(state.range(1)));
  for (auto _ : state) benchmark::DoNotOptimize(f.problem.Linearize());
  state.counters["edges"] = static_cast<double>(f.sim.noisy.edges().size());
}

void BM_Factorize(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)), static_cast<CholeskyKind>(state.range(1)), 2);
  f.problem.Linearize();
  double step = 0;
  for (auto _ : state) benchmark::DoNotOptimize(f.problem.SolveStep(0.0, &step));
  state.counters["n"] = f.problem.TangentDimension();
  state.counters["nnz_L"] = static_cast<double>(f.problem.FactorNonZeros());
}

// The same two hot spots on the shared files, where the datasets are present.
const char* const kFiles[] = {"2d/city10000.g2o", "3d/sphere2500.g2o"};

std::string FilePath(int k) { return std::string(CAIRN_DATASETS) + "/g2o/" + kFiles[k]; }

void BM_FileLinearize(benchmark::State& state) {
  const std::string path = FilePath(static_cast<int>(state.range(0)));
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("dataset not found: " + path).c_str());
    return;
  }
  Fixture f(0, CholeskyKind::kAuto, 2, path);
  for (auto _ : state) benchmark::DoNotOptimize(f.problem.Linearize());
  state.SetLabel(kFiles[state.range(0)]);
}

void BM_FileFactorize(benchmark::State& state) {
  const std::string path = FilePath(static_cast<int>(state.range(0)));
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("dataset not found: " + path).c_str());
    return;
  }
  Fixture f(0, static_cast<CholeskyKind>(state.range(1)), 2, path);
  f.problem.Linearize();
  double step = 0;
  for (auto _ : state) benchmark::DoNotOptimize(f.problem.SolveStep(0.0, &step));
  state.SetLabel(std::string(kFiles[state.range(0)]) + " " + ToString(f.problem.LinearSolver()));
  state.counters["nnz_L"] = static_cast<double>(f.problem.FactorNonZeros());
}

BENCHMARK(BM_FileLinearize)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
// Args: file, CholeskyKind (1 supernodal, 2 simplicial, 4 Eigen LDLT, 5 two
// halves at once).
BENCHMARK(BM_FileFactorize)->Args({0, 1})->Args({0, 2})->Args({0, 4})->Args({0, 5})
    ->Args({1, 1})->Args({1, 2})->Args({1, 5})->Unit(benchmark::kMillisecond);

// Args: dimension, threads.
BENCHMARK(BM_Linearize)->Args({2, 1})->Args({2, 2})->Args({3, 1})->Args({3, 2})
    ->Unit(benchmark::kMillisecond);
// Args: dimension, CholeskyKind (1 supernodal, 2 simplicial, 4 Eigen LDLT, 5 two
// halves at once).
BENCHMARK(BM_Factorize)->Args({2, 1})->Args({2, 2})->Args({2, 4})->Args({2, 5})->Args({3, 1})
    ->Args({3, 2})->Args({3, 5})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cairn

BENCHMARK_MAIN();
