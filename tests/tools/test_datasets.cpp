// `cairn info` on every shared g2o file: counts as the datasets' README
// tables them, and initial chi-squared as the reference figures give it.
#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "test_util.h"

namespace {

struct Expected {
  const char* file;
  int vertices;  // as the file gives them; 0: built from the edges
  int edges;
  int built_vertices;
  double chi2;  // initial, from the file's own vertices
};

// chi2 from ../shared/reference-figures.md where it is given.
const Expected kFiles[] = {
    {"g2o/2d/intel.g2o", 1728, 2512, 1728, 551.7357308},
    {"g2o/2d/MIT.g2o", 808, 827, 808, 4414181663.0},
    {"g2o/2d/city10000.g2o", 10000, 20687, 10000, 654162688.5},
    {"g2o/2d/manhattan.g2o", 0, 5453, 3500, 0},
    {"g2o/2d/CSAIL.g2o", 0, 1172, 1045, 0},
    {"g2o/3d/tinyGrid3D.g2o", 9, 11, 9, 213.0643706},
    {"g2o/3d/smallGrid3D.g2o", 125, 297, 125, 115957.9979},
    {"g2o/3d/sphere2500.g2o", 2500, 4949, 2500, 2547810.899},
    {"g2o/3d/parking-garage.g2o", 1661, 6275, 1661, 16720.01817},
    {"g2o/3d/sphere_bignoise_vertex3.g2o", 2200, 8647, 2200, 176631219.8},
};

class InfoOnDataset : public ::testing::TestWithParam<Expected> {};

TEST_P(InfoOnDataset, CountsAndChi2) {
  const Expected& e = GetParam();
  const std::string path = cairn::testing::DatasetPath(e.file);
  CAIRN_REQUIRE_DATASET(path);
  int status = -1;
  const std::string json = cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " info --json '" + path + "'", &status);
  ASSERT_EQ(status, 0) << json;
  EXPECT_EQ(cairn::testing::JsonNumber(json, "vertices"), e.built_vertices);
  EXPECT_EQ(cairn::testing::JsonNumber(json, "odometry_edges") + cairn::testing::JsonNumber(json, "loop_closures") +
                cairn::testing::JsonNumber(json, "priors"),
            e.edges);
  EXPECT_EQ(cairn::testing::JsonNumber(json, "odometry_edges"), e.built_vertices - 1);
  EXPECT_EQ(cairn::testing::JsonNumber(json, "components"), 1);
  if (e.chi2 > 0) EXPECT_NEAR(cairn::testing::JsonNumber(json, "chi2") / e.chi2, 1.0, 5e-10) << json;
}

INSTANTIATE_TEST_SUITE_P(SharedFiles, InfoOnDataset, ::testing::ValuesIn(kFiles),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           name = name.substr(name.rfind('/') + 1);
                           return std::regex_replace(name, std::regex("[^A-Za-z0-9]"), "_");
                         });

TEST(InfoTool, BadFileExitsNonZeroWithFileAndLine) {
  const std::string path = cairn::testing::TempDir() + "/cairn_bad.g2o";
  FILE* f = std::fopen(path.c_str(), "w");
  std::fputs("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 oops\n", f);
  std::fclose(f);
  int status = 0;
  const std::string out = cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " info '" + path + "' 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find(path + ":2: "), std::string::npos) << out;
}

}  // namespace
