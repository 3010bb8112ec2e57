// Load a g2o file, optimise it with each solver and compare. Without an
// argument it simulates a small noisy graph and writes it first.
//   compare_solvers [FILE.g2o]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <cairn/cairn.h>

int main(int argc, char** argv) {
  std::string path = argc > 1 ? argv[1] : "compare_solvers_input.g2o";
  if (argc <= 1) {
    cairn::SimulationOptions sim;
    sim.dimension = 2;
    sim.poses = 1000;
    sim.seed = 3;
    cairn::WriteG2o(cairn::Simulate(sim).noisy, path);
    std::printf("wrote a simulated graph to %s\n", path.c_str());
  }
  const cairn::PoseGraph graph = cairn::ReadGraph(path);
  std::printf("%s: %zu vertices, %zu edges\n", path.c_str(), graph.vertices().size(),
              graph.edges().size());

  // Each solver optimises its own copy in place.
  cairn::PoseGraph by_ceres = graph, by_gn = graph;
  const cairn::SolveResult ceres = cairn::SolveWithCeres(by_ceres, cairn::CeresOptions{});
  const cairn::SolveResult gn = cairn::SolveGaussNewton(by_gn, cairn::GaussNewtonOptions{});
  for (const cairn::SolveResult* r : {&ceres, &gn})
    std::printf("%-6s chi2 %.10g -> %.10g  %2d iterations  %.3f s  %s\n", r->solver.c_str(),
                r->initial_chi2, r->final_chi2, r->iterations, r->time_s, r->termination.c_str());

  // The same factors and gauge: the optima agree to the solvers' tolerance.
  double largest = 0;
  for (size_t i = 0; i < graph.vertices().size(); ++i)
    for (int k = 0; k < graph.ParameterSize(); ++k)
      largest = std::max(largest, std::abs(by_ceres.vertices()[i].x[k] - by_gn.vertices()[i].x[k]));
  std::printf("largest difference between the two estimates: %.3g\n", largest);
  const double gap = std::abs(ceres.final_chi2 - gn.final_chi2) / ceres.final_chi2;
  return ceres.usable && gn.usable && gap < 1e-3 ? 0 : 1;
}
