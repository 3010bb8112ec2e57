// Build a small pose graph in code and optimise it: a square driven twice
// with biased odometry, one loop closure per lap, the first pose fixed.
#include <cmath>  // M_PI
#include <cstdio>

#include <cairn/cairn.h>

int main() {
  cairn::PoseGraph graph(2);
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  information.diagonal() << 400, 400, 2500;  // sigma 5 cm, 1.1 degrees

  // The odometry reports 1 m and 90 degrees at each corner; the estimate we
  // start from drifts a little each step, as dead reckoning does.
  const cairn::SE2 step(1.0, 0.0, M_PI / 2);
  const cairn::SE2 drift(1.03, 0.02, M_PI / 2 + 0.03);
  cairn::SE2 estimate;
  graph.AddVertex(0, estimate, /*fixed=*/true);
  for (int i = 1; i <= 8; ++i) {
    estimate = estimate * drift;
    graph.AddVertex(i, estimate);
    cairn::Edge odometry;
    odometry.kind = cairn::EdgeKind::kOdometry;
    odometry.from = i - 1;
    odometry.to = i;
    odometry.z = cairn::ToParams(step);
    odometry.information.SetTopLeft(information);
    graph.AddEdge(odometry);
  }
  // Back at the start after each lap: poses 4 and 8 are where pose 0 is.
  for (int i : {4, 8}) {
    cairn::Edge loop;
    loop.kind = cairn::EdgeKind::kLoopClosure;
    loop.from = 0;
    loop.to = i;
    loop.z = cairn::ToParams(cairn::SE2(0, 0, 0));
    loop.information.SetTopLeft(information);
    graph.AddEdge(loop);
  }

  cairn::CeresOptions options;
  options.threads = 1;
  const cairn::SolveResult result = cairn::SolveWithCeres(graph, options);
  std::printf("chi2 %.6g -> %.6g in %d iterations (%s)\n", result.initial_chi2,
              result.final_chi2, result.iterations, result.termination.c_str());
  for (const cairn::Vertex& v : graph.vertices())
    std::printf("pose %lld: x %.4f  y %.4f  theta %.4f\n", static_cast<long long>(v.id), v.x[0],
                v.x[1], v.x[2]);
  return result.usable && result.final_chi2 < 1e-6 ? 0 : 1;
}
