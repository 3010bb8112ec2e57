// The intel log end to end through the `cairn` tool: map, then eval. Slow
// (seconds, not milliseconds): CTest label "slow", so that
// `ctest -LE slow` leaves it out and `ctest -L slow` runs it alone.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "test_util.h"

namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": *([-0-9.eE+]+)"))) return -1;
  return std::stod(m[1]);
}

TEST(IntelEndToEnd, MapsUnderFifteenCentimetresAte) {
  const std::string log = cairn::testing::DatasetPath("carmen/intel-corrected.log.gz");
  CAIRN_REQUIRE_DATASET(log);
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_intel_e2e";
  std::filesystem::create_directories(dir);
  const std::string prefix = (dir / "intel").string();
  const std::string map_cmd = std::string(CAIRN_TOOL) + " map " + log + " -o " + prefix +
                              " --graph " + prefix + ".g2o --quiet 2> " + prefix + ".stderr";
  ASSERT_EQ(std::system(map_cmd.c_str()), 0) << Slurp(prefix + ".stderr");
  for (const char* suffix : {".pgm", ".yaml", ".png", "_trajectory.svg", "_trajectory.tum", ".g2o"})
    EXPECT_TRUE(std::filesystem::exists(prefix + suffix)) << suffix;
  const std::string eval_cmd = std::string(CAIRN_TOOL) + " eval " + prefix + "_trajectory.tum " +
                               log + " --json " + prefix + ".json > /dev/null";
  ASSERT_EQ(std::system(eval_cmd.c_str()), 0);
  const std::string json = Slurp(prefix + ".json");
  const double ate = JsonNumber(json, "ate_rmse");
  EXPECT_GT(ate, 0);
  EXPECT_LE(ate, 0.15) << json;
  EXPECT_GT(JsonNumber(json, "matched"), 800) << json;
  EXPECT_GE(JsonNumber(json, "rpe_trans_rmse"), 0);
  EXPECT_GE(JsonNumber(json, "rpe_rot_rmse_deg"), 0);
  const std::string yaml = Slurp(prefix + ".yaml");
  EXPECT_NE(yaml.find("image: intel.pgm"), std::string::npos);
  EXPECT_NE(yaml.find("resolution: 0.05"), std::string::npos);
}

}  // namespace
