// The tool on graphs with landmarks: simulate writes them, info counts them,
// optimize keeps every landmark vertex and edge with both solvers, --plot
// draws them, and the commands that treat every vertex as a pose refuse
// such a graph.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "test_util.h"

namespace cairn {
namespace {

std::string Tool() { return CAIRN_TOOL; }

std::string Simulated(int dim) {
  const std::string path = testing::TempDir() + "/lmk" + std::to_string(dim) + ".g2o";
  int status = -1;
  const std::string log = testing::RunCommand(
      Tool() + " simulate -o '" + path + "' --dim " + std::to_string(dim) +
          " --poses 120 --landmarks 25 --nodes-per-lap 20 --radius 12 --seed 3 2>&1",
      &status);
  EXPECT_EQ(status, 0) << log;
  return path;
}

TEST(LandmarksTool, InfoCountsThem) {
  for (int dim : {2, 3}) {
    const std::string path = Simulated(dim);
    const PoseGraph g = ReadGraph(path);
    int status = -1;
    const std::string json = testing::RunCommand(Tool() + " info --json '" + path + "'", &status);
    ASSERT_EQ(status, 0) << json;
    EXPECT_EQ(testing::JsonNumber(json, "landmarks"), 25);
    EXPECT_EQ(testing::JsonNumber(json, "poses"), 120);
    EXPECT_EQ(testing::JsonNumber(json, "landmark_edges"), g.CountEdges(EdgeKind::kLandmark));
    EXPECT_GT(testing::JsonNumber(json, "landmark_edges"), 25);
    EXPECT_EQ(testing::JsonNumber(json, "components"), 1);
    const std::string text = testing::RunCommand(Tool() + " info '" + path + "'", &status);
    EXPECT_NE(text.find("landmarks       25"), std::string::npos) << text;
    // The truth file holds the same landmarks at their true places.
    const PoseGraph truth = ReadGraph(path.substr(0, path.size() - 4) + "_truth.g2o");
    EXPECT_EQ(truth.CountLandmarks(), 25u);
    EXPECT_LT(Chi2(truth), Chi2(g));
  }
}

TEST(LandmarksTool, OptimizeKeepsEveryLandmarkWithBothSolvers) {
  for (int dim : {2, 3}) {
    const std::string in = Simulated(dim);
    const PoseGraph input = ReadGraph(in);
    for (const char* solver : {"ceres", "gn"}) {
      const std::string out = testing::TempDir() + "/lmk_out.g2o";
      int status = -1;
      const std::string log = testing::RunCommand(Tool() + " optimize '" + in + "' -o '" + out +
                                                      "' --solver " + solver + " --quiet 2>&1",
                                                  &status);
      ASSERT_EQ(status, 0) << log;
      const PoseGraph g = ReadGraph(out);
      EXPECT_EQ(g.CountLandmarks(), input.CountLandmarks()) << solver;
      EXPECT_EQ(g.CountEdges(EdgeKind::kLandmark), input.CountEdges(EdgeKind::kLandmark));
      EXPECT_EQ(g.edges().size(), input.edges().size());
      EXPECT_LT(Chi2(g), 0.5 * Chi2(input)) << solver;
    }
  }
}

// Both panels (before, after) draw every landmark as a dot.
TEST(LandmarksTool, PlotDrawsLandmarks) {
  const std::string in = Simulated(2), out = testing::TempDir() + "/lmk_plot.g2o";
  const std::string svg = testing::TempDir() + "/lmk_plot.svg";
  int status = -1;
  const std::string log = testing::RunCommand(
      Tool() + " optimize '" + in + "' -o '" + out + "' --plot '" + svg + "' --quiet 2>&1", &status);
  ASSERT_EQ(status, 0) << log;
  std::ifstream f(svg);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  size_t dots = 0;
  for (size_t at = text.find("<circle"); at != std::string::npos; at = text.find("<circle", at + 1))
    ++dots;
  EXPECT_EQ(dots, 2 * ReadGraph(in).CountLandmarks());
}

TEST(LandmarksTool, PoseOnlyCommandsRefuseLandmarks) {
  const std::string in = Simulated(2), out = testing::TempDir() + "/lmk_refused.g2o";
  for (const std::string args : {"corrupt '" + in + "' -o '" + out + "' --outliers 3",
                                 "optimize '" + in + "' -o '" + out + "' --reject-outliers",
                                 "calibrate --g2o '" + in + "' --odometry '" + in + "'"}) {
    int status = -1;
    const std::string log = testing::RunCommand(Tool() + " " + args + " 2>&1", &status);
    EXPECT_NE(status, 0) << args;
    EXPECT_NE(log.find("cairn: "), std::string::npos) << log;
    EXPECT_NE(log.find("does not handle landmarks"), std::string::npos) << log;
  }
}

}  // namespace
}  // namespace cairn
