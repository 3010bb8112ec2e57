// Incremental use as a robot runs: poses, odometry and loop closures arrive
// one at a time; the graph is re-optimised every ten poses, warm-started,
// and the uncertainty of the newest pose is read off at the end.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <cairn/solvers/covariance.h>
#include <cairn/solvers/incremental.h>
#include <cairn/graph/simulate.h>

int main() {
  // A simulated run stands in for the robot's front-end.
  cairn::SimulationOptions sim_options;
  sim_options.poses = 500;
  sim_options.seed = 11;
  const cairn::Simulation sim = cairn::Simulate(sim_options);
  const auto& edges = sim.noisy.edges();

  cairn::IncrementalOptimizer optimizer(2);
  optimizer.AddPose(0, cairn::SE2());
  size_t next = 0;
  int total_iterations = 0, solves = 0;
  for (int64_t i = 1; i < sim_options.poses; ++i) {
    // Odometry first: the new pose's estimate is the last one moved by it.
    const cairn::Edge& odometry = edges[next];
    optimizer.AddPose(i, optimizer.PoseSE2(i - 1) * cairn::ToSE2(odometry.z));
    // Then every measurement that ends at the new pose (odometry and loop closures).
    for (; next < edges.size() && std::max(edges[next].from, edges[next].to) <= i; ++next)
      optimizer.AddEdge(edges[next]);
    if (i % 10 == 0 || i + 1 == sim_options.poses) {
      const cairn::SolveResult r = optimizer.Optimize(cairn::SolverKind::kGaussNewton);
      if (i % 100 == 0 || i + 1 == sim_options.poses)
        std::printf("after pose %4lld: chi2 %10.4f  %d iterations  %.1f ms\n",
                  static_cast<long long>(i), r.final_chi2, r.iterations, 1e3 * r.time_s);
      total_iterations += r.iterations;
      ++solves;
    }
  }
  std::printf("%d solves, %d iterations in all; %d fresh orderings, %d extended analyses\n",
              solves, total_iterations, optimizer.gauss_newton_reorderings(),
              optimizer.gauss_newton_extensions());

  const int64_t last = sim_options.poses - 1;
  const auto cov = optimizer.MarginalCovariances({last}, cairn::SolverKind::kGaussNewton);
  std::printf("pose %lld: sigma x %.3f m, y %.3f m, theta %.4f rad (own frame)\n",
              static_cast<long long>(last), std::sqrt(cov[0](0, 0)), std::sqrt(cov[0](1, 1)),
              std::sqrt(cov[0](2, 2)));
  return 0;
}
