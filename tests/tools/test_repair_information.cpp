// `--repair-information` end to end: a file with indefinite information is
// refused by default (FILE:LINE, naming the option); with the option the
// matrices are repaired, counted on stderr and in the reports, and the
// solve converges. An undetermined graph is refused by optimize and compare
// with the vertex and direction named.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

namespace cairn {
namespace {

std::string Tool() { return CAIRN_TOOL; }

std::string Slurp(const std::string& path) {
  std::ifstream f(path);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// A simulated graph with every second loop closure's information made
// indefinite (not odometry: clipping a bridge of the graph would leave what
// lies beyond it free, which FindUndetermined rightly refuses): in a random direction u, -0.4 times the largest eigenvalue of
// the rest (P Omega P, P = I - u u^T), as scripts/make-indefinite.py does.
// Returns how many, and the first such line.
size_t WriteIndefinite(int dimension, const std::string& path, size_t* first_line) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = 150;
  o.nodes_per_lap = 15;
  o.radius = 10;
  o.seed = 5;
  PoseGraph g = Simulate(o).noisy;
  const int n = g.TangentSize();
  std::mt19937 rng(9);
  std::normal_distribution<double> gauss(0, 1);
  size_t changed = 0, loops = 0, first = 0;
  for (size_t k = 0; k < g.edges().size(); ++k) {
    Edge e = g.edges()[k];
    if (e.kind != EdgeKind::kLoopClosure || loops++ % 2 != 0) continue;
    if (changed == 0) first = k;
    Eigen::VectorXd u(n);
    for (int i = 0; i < n; ++i) u[i] = gauss(rng);
    u.normalize();
    const Eigen::MatrixXd p = Eigen::MatrixXd::Identity(n, n) - u * u.transpose();
    const Eigen::MatrixXd rest = p * e.information.topLeftCorner(n, n) * p;
    const double largest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(rest).eigenvalues()[n - 1];
    e.information.SetTopLeft(rest - 0.4 * largest * u * u.transpose());
    g.SetEdge(k, e);
    ++changed;
  }
  WriteG2o(g, path);
  std::ifstream in(path);
  std::string line;
  size_t edges = 0;
  for (size_t no = 1; std::getline(in, line); ++no)
    if (line.rfind("EDGE", 0) == 0 && edges++ == first) {
      *first_line = no;
      break;
    }
  return changed;
}

class RepairInformation : public ::testing::TestWithParam<int> {};

TEST_P(RepairInformation, RefusedByDefaultRepairedOnRequest) {
  const std::string dir = testing::TempDir();
  const std::string in = dir + "/indefinite" + std::to_string(GetParam()) + ".g2o";
  size_t line = 0;
  const size_t changed = WriteIndefinite(GetParam(), in, &line);
  ASSERT_GT(changed, 10u);
  int status = -1;
  std::string log = testing::RunCommand(Tool() + " optimize '" + in + "' -o '" + in +
                                            ".out.g2o' 2>&1", &status);
  EXPECT_NE(status, 0) << log;
  EXPECT_NE(log.find("cairn: " + in + ":" + std::to_string(line) + ": information matrix is indefinite"),
            std::string::npos) << log;
  EXPECT_NE(log.find("--repair-information"), std::string::npos) << log;
  EXPECT_FALSE(std::filesystem::exists(in + ".out.g2o"));

  for (const char* solver : {"ceres", "gn"}) {
    const std::string report = in + "." + solver + ".json";
    log = testing::RunCommand(Tool() + " --repair-information optimize --init chordal --solver " +
                                  solver + " '" + in + "' -o '" + in + ".out.g2o' --report '" +
                                  report + "' 2>&1",
                              &status);
    ASSERT_EQ(status, 0) << log;
    EXPECT_NE(log.find(std::to_string(changed) + " of "), std::string::npos) << log;
    EXPECT_NE(log.find("were indefinite"), std::string::npos) << log;
    const std::string json = Slurp(report);
    EXPECT_EQ(testing::JsonNumber(json, "repaired_information"), static_cast<double>(changed));
    EXPECT_NEAR(testing::JsonNumber(json, "repaired_information_largest_clipped"), 0.4, 1e-6);
    EXPECT_NE(json.find("\"converged\": true"), std::string::npos) << json;
    EXPECT_LT(testing::JsonNumber(json, "final_chi2"), testing::JsonNumber(json, "initial_chi2"));
  }

  // info and compare take the option too, and count the same.
  const std::string info = testing::RunCommand(
      Tool() + " info --json --repair-information '" + in + "' 2>/dev/null", &status);
  ASSERT_EQ(status, 0) << info;
  EXPECT_EQ(testing::JsonNumber(info, "repaired_information"), static_cast<double>(changed));
  testing::RunCommand(Tool() + " info '" + in + "' 2>&1", &status);
  EXPECT_NE(status, 0);
  const std::string cmp = in + ".compare.json";
  log = testing::RunCommand(Tool() + " compare --repair-information --init chordal '" + in +
                                "' --json '" + cmp + "' 2>&1",
                            &status);
  ASSERT_EQ(status, 0) << log;
  EXPECT_EQ(testing::JsonNumber(Slurp(cmp), "repaired_information"), static_cast<double>(changed));
}

INSTANTIATE_TEST_SUITE_P(Dimensions, RepairInformation, ::testing::Values(2, 3),
                         [](const auto& info) { return std::to_string(info.param) + "D"; });

// Vertex 2's heading is in no residual: a position-only prior and an edge
// towards it without rotation information.
TEST(Undetermined, OptimizeAndCompareNameTheVertexAndDirection) {
  const std::string path = testing::TempDir() + "/free_heading.g2o";
  std::ofstream(path) << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0.1 0.5\n"
                         "EDGE_SE2 0 1 1 0 0 10 0 0 10 0 10\n"
                         "EDGE_SE2 1 2 1 0 0 10 0 0 10 0 0\n"
                         "EDGE_PRIOR_SE2 2 2 0 0 5 0 0 5 0 0\n"
                         "FIX 0\n";
  const std::string what = "vertex 2: rotation about z is not constrained by any edge";
  for (const char* solver : {"ceres", "gn"}) {
    int status = -1;
    const std::string log = testing::RunCommand(Tool() + " optimize --solver " + solver + " '" +
                                                    path + "' -o '" + path + ".out.g2o' 2>&1",
                                                &status);
    EXPECT_EQ(status, 1) << log;
    EXPECT_NE(log.find(what), std::string::npos) << log;
    EXPECT_EQ(log.find("nan"), std::string::npos) << log;
  }
  int status = -1;
  const std::string log = testing::RunCommand(Tool() + " compare '" + path + "' 2>&1", &status);
  EXPECT_EQ(status, 1) << log;
  EXPECT_NE(log.find("cairn: ceres failed: " + what), std::string::npos) << log;
}

}  // namespace
}  // namespace cairn
