// `cairn optimize` end to end: the graph, report and plot it writes, both
// solvers, TORO input, quiet output, and its refusals of bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

namespace cairn {
namespace {

Simulation Simulated(int dimension, int poses) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = poses;
  o.nodes_per_lap = 20;
  o.radius = 10;
  o.seed = 7;
  return Simulate(o);
}

std::string Tool() { return CAIRN_TOOL; }

TEST(OptimizeTool, WritesGraphReportAndPlot) {
  Simulation sim = Simulated(2, 200);
  const std::string dir = cairn::testing::TempDir();
  const std::string in = dir + "/cairn_opt_in.g2o", out = dir + "/cairn_opt_out.g2o";
  const std::string report = dir + "/cairn_opt.json", plot = dir + "/cairn_opt.svg";
  WriteG2o(sim.noisy, in);
  int status = -1;
  const std::string log = testing::RunCommand(Tool() + " optimize '" + in + "' -o '" + out +
                                                  "' --init file --robust huber:1 --report '" + report +
                                                  "' --plot '" + plot + "' 2>&1",
                                              &status);
  ASSERT_EQ(status, 0) << log;
  // One progress line per iteration, then the summary.
  EXPECT_NE(log.find("iter   0  chi2"), std::string::npos) << log;
  std::ifstream rf(report);
  const std::string json((std::istreambuf_iterator<char>(rf)), std::istreambuf_iterator<char>());
  const double final_chi2 = testing::JsonNumber(json, "final_chi2");
  EXPECT_LT(final_chi2, testing::JsonNumber(json, "initial_chi2"));
  EXPECT_GT(testing::JsonNumber(json, "iterations"), 0);
  EXPECT_GT(testing::JsonNumber(json, "time_s"), 0);
  EXPECT_NE(json.find("\"termination\""), std::string::npos);
  EXPECT_NE(json.find("\"robust\": \"huber:1\""), std::string::npos);
  EXPECT_NEAR(Chi2(ReadGraph(out)), final_chi2, 1e-6 * final_chi2);
  std::ifstream pf(plot);
  const std::string svg((std::istreambuf_iterator<char>(pf)), std::istreambuf_iterator<char>());
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("#d62728"), std::string::npos);  // loop closures drawn
}

TEST(OptimizeTool, GaussNewtonReachesWhatCeresReaches) {
  Simulation sim = Simulated(3, 200);
  const std::string dir = cairn::testing::TempDir();
  const std::string in = dir + "/cairn_gn_in.g2o";
  WriteG2o(sim.noisy, in);
  double final_chi2[2];
  int k = 0;
  for (const char* solver : {"ceres", "gn"}) {
    const std::string report = dir + "/cairn_gn_" + solver + ".json";
    int status = -1;
    const std::string log = testing::RunCommand(
        Tool() + " optimize --quiet --solver " + solver + " '" + in + "' -o '" + in +
            ".out.g2o' --report '" + report + "' 2>&1",
        &status);
    ASSERT_EQ(status, 0) << log;
    std::ifstream rf(report);
    const std::string json((std::istreambuf_iterator<char>(rf)), std::istreambuf_iterator<char>());
    EXPECT_NE(json.find(std::string("\"solver\": \"") + solver + "\""), std::string::npos);
    final_chi2[k++] = testing::JsonNumber(json, "final_chi2");
  }
  EXPECT_NEAR(final_chi2[1], final_chi2[0], 1e-6 * final_chi2[0]);
}

// A TORO square whose loop closure disagrees with the odometry by 0.4 m:
// read as TORO, written as g2o, chi2 lowered, vertex 0 held.
TEST(OptimizeTool, ReadsToroWritesG2o) {
  const std::string in = cairn::testing::TempDir() + "/cairn_toro.graph";
  const std::string out = in + ".g2o";
  std::ofstream(in) << "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 1.5708\nVERTEX2 2 1 1 3.1416\n"
                       "VERTEX2 3 0 1 -1.5708\n"
                       "EDGE2 0 1 1 0 1.5708 1 0 1 1 0 0\n"
                       "EDGE2 1 2 1 0 1.5708 1 0 1 1 0 0\n"
                       "EDGE2 2 3 1 0 1.5708 1 0 1 1 0 0\n"
                       "EDGE2 3 0 1.4 0 1.5708 1 0 1 1 0 0\n";
  int status = -1;
  const std::string log =
      testing::RunCommand(Tool() + " optimize --quiet '" + in + "' -o '" + out + "' 2>&1", &status);
  ASSERT_EQ(status, 0) << log;
  const PoseGraph before = ReadGraph(in), after = ReadGraph(out);
  std::ifstream f(out);
  std::string first;
  std::getline(f, first);
  EXPECT_EQ(first.rfind("VERTEX_SE2 0 ", 0), 0u) << first;
  EXPECT_LT(Chi2(after), 0.5 * Chi2(before));
  EXPECT_EQ(after.vertex(0).x, before.vertex(0).x);
}

TEST(OptimizeTool, WritesToroUnderAGraphName) {
  Simulation sim = Simulated(3, 60);
  const std::string in = cairn::testing::TempDir() + "/cairn_to_toro.g2o";
  WriteG2o(sim.noisy, in);
  int status = -1;
  for (const char* out : {"/cairn_to_toro.out.graph", "/cairn_to_toro.out.g2o"}) {
    const std::string log = testing::RunCommand(
        Tool() + " optimize --quiet --solver gn '" + in + "' -o '" + testing::TempDir() + out + "' 2>&1",
        &status);
    ASSERT_EQ(status, 0) << log;
  }
  std::ifstream f(testing::TempDir() + "/cairn_to_toro.out.graph");
  std::string first;
  std::getline(f, first);
  EXPECT_EQ(first.rfind("VERTEX3 0 ", 0), 0u) << first;
  const double toro = Chi2(ReadGraph(testing::TempDir() + "/cairn_to_toro.out.graph"));
  const double g2o = Chi2(ReadGraph(testing::TempDir() + "/cairn_to_toro.out.g2o"));
  EXPECT_LT(g2o, 0.5 * Chi2(sim.noisy));
  EXPECT_NEAR(toro, g2o, 1e-9 * g2o);
}

// TORO has no priors: refused once the input is read, before the solve.
TEST(OptimizeTool, RefusesToroForAGraphWithPriorsBeforeTheSolve) {
  const std::string in = cairn::testing::TempDir() + "/cairn_prior.g2o";
  std::ofstream(in) << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
                       "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_PRIOR_SE2 0 0 0 0 1 0 0 1 0 1\n";
  const std::string out = in + ".graph", report = in + ".json";
  int status = 0;
  const std::string log = testing::RunCommand(
      Tool() + " optimize '" + in + "' -o '" + out + "' --report '" + report + "' 2>&1", &status);
  EXPECT_EQ(status, 1) << log;
  EXPECT_EQ(log.rfind("cairn: " + out + ": TORO has no prior edges", 0), 0u) << log;
  EXPECT_EQ(log.find("iter"), std::string::npos) << log;
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_FALSE(std::filesystem::exists(report));
}

TEST(Cli, VersionNamesCairnAndItsLibraries) {
  int status = -1;
  const std::string out = testing::RunCommand(Tool() + " --version 2>&1", &status);
  EXPECT_EQ(status, 0);
  EXPECT_EQ(out.rfind("cairn " CAIRN_TEST_VERSION " (Ceres ", 0), 0u) << out;
  EXPECT_NE(out.find("Eigen "), std::string::npos) << out;
}

TEST(OptimizeTool, QuietPrintsNothing) {
  Simulation sim = Simulated(3, 60);
  const std::string in = cairn::testing::TempDir() + "/cairn_q_in.g2o";
  WriteG2o(sim.noisy, in);
  int status = -1;
  const std::string log = testing::RunCommand(
      Tool() + " optimize --quiet '" + in + "' -o '" + in + ".out.g2o' 2>&1", &status);
  EXPECT_EQ(status, 0);
  EXPECT_EQ(log, "");
}

TEST(OptimizeTool, BadInputNamesFileAndLine) {
  const std::string path = cairn::testing::TempDir() + "/cairn_opt_bad.g2o";
  std::ofstream(path) << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0\n";
  int status = 0;
  const std::string out = testing::RunCommand(
      Tool() + " optimize '" + path + "' -o '" + path + ".out.g2o' 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("cairn: " + path + ":3: "), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(path + ".out.g2o"));
}

TEST(OptimizeTool, RejectsBadOptions) {
  for (const char* args : {"--robust tukey:1", "--solver nope", "--method newton",
                           "--sparse mkl", "--max-iterations -1", "--linear-solver mkl",
                           "--gn-factor-memory lots", "--gn-factor-memory -1"}) {
    int status = 0;
    const std::string out = testing::RunCommand(
        Tool() + " optimize in.g2o -o out.g2o " + args + " 2>&1", &status);
    EXPECT_EQ(status, 2) << args << ": " << out;
    EXPECT_EQ(out.rfind("cairn: ", 0), 0u) << out;
  }
}

// --gn-factor-memory: a graph whose factor is kept half on disk (here: any
// size over 0 MB) is solved to the very same graph as in memory, and the
// report says which way it went.
TEST(OptimizeTool, FactorHalfOnDiskWritesTheSameGraph) {
  Simulation sim = Simulated(3, 2000);
  const std::string dir = cairn::testing::TempDir();
  const std::string in = dir + "/cairn_spill_in.g2o";
  WriteG2o(sim.noisy, in);
  std::string graphs[2], reports[2];
  const char* limits[2] = {"unlimited", "0"};
  for (int k = 0; k < 2; ++k) {
    const std::string out = dir + "/cairn_spill_out" + std::to_string(k) + ".g2o";
    const std::string report = out + ".json";
    int status = -1;
    const std::string log = testing::RunCommand(
        "TMPDIR='" + dir + "' " + Tool() + " optimize --solver gn --quiet --gn-factor-memory " +
            limits[k] + " '" + in + "' -o '" + out + "' --report '" + report + "' 2>&1",
        &status);
    ASSERT_EQ(status, 0) << log;
    std::ifstream g(out), r(report);
    graphs[k].assign(std::istreambuf_iterator<char>(g), std::istreambuf_iterator<char>());
    reports[k].assign(std::istreambuf_iterator<char>(r), std::istreambuf_iterator<char>());
  }
  ASSERT_NE(reports[0].find("two halves at once"), std::string::npos) << reports[0];
  EXPECT_NE(reports[1].find("two halves one at a time"), std::string::npos) << reports[1];
  EXPECT_NE(reports[1].find("kept on disk in " + dir), std::string::npos) << reports[1];
  EXPECT_FALSE(graphs[0].empty());
  EXPECT_EQ(graphs[0], graphs[1]);
}

TEST(OptimizeTool, HelpDescribesEveryOption) {
  int status = -1;
  const std::string help = testing::RunCommand(Tool() + " optimize --help", &status);
  EXPECT_EQ(status, 0);
  for (const char* opt : {"--output", "-o", "--solver", "--max-iterations", "--robust",
                          "--threads", "--report", "--plot", "--quiet", "--method", "--sparse"})
    EXPECT_NE(help.find(opt), std::string::npos) << opt;
}

}  // namespace
}  // namespace cairn
