// The intel log end to end through the `cairn` tool: map, then eval. Slow
// (seconds, not milliseconds): CTest label "slow", so that
// `ctest -LE slow` leaves it out and `ctest -L slow` runs it alone.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <regex>
#include <set>
#include <sstream>
#include <utility>

#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"
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

// `cairn map`'s ATE on a harder version of a shared log that
// scripts/frontend_harness.py makes (the default settings).
double HarnessAte(const std::string& log_name, const std::string& kase, int seed) {
  const std::string log = cairn::testing::DatasetPath("carmen/" + log_name + "-corrected.log.gz");
  if (!std::filesystem::exists(log)) return -1;
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_harness";
  std::filesystem::create_directories(dir);
  const std::string out = (dir / (log_name + "_" + kase + "_" + std::to_string(seed))).string();
  const std::string make = "python3 " CAIRN_SOURCE_DIR "/scripts/frontend_harness.py make " + log + " " +
                           kase + " " + out + ".log --seed " + std::to_string(seed);
  if (std::system(make.c_str()) != 0) return -2;
  const std::string map = std::string(CAIRN_TOOL) + " map " + out + ".log -o " + out + " --quiet 2> " +
                          out + ".stderr";
  if (std::system(map.c_str()) != 0) return -3;
  std::smatch m;
  const std::string err = Slurp(out + ".stderr");
  if (!std::regex_search(err, m, std::regex("result *: ATE ([0-9.]+) m"))) return -4;
  return std::stod(m[1]);
}

// Each (log, seed) run of a harness case within `bound` m ATE; skipped
// when a log is absent.
void ExpectRunsWithin(const std::string& kase,
                      std::initializer_list<std::pair<const char*, int>> runs, double bound) {
  for (const auto& [log, seed] : runs) {
    const double ate = HarnessAte(log, kase, seed);
    if (ate == -1) GTEST_SKIP() << "dataset not found: " << log << "-corrected.log.gz";
    EXPECT_GT(ate, 0) << log << " " << kase << " seed " << seed;
    EXPECT_LE(ate, bound) << log << " " << kase << " seed " << seed;
  }
}

void ExpectGlitchRunsWithin(std::initializer_list<std::pair<const char*, int>> runs, double bound) {
  ExpectRunsWithin("glitch", runs, bound);
}

// Three steps of aces' odometry with the heading 60-90 degrees off (and up
// to 1 m of translation): 22.9 m ATE before tracking judged its matches.
TEST(HarnessEndToEnd, AcesWithOdometryGlitches) {
  ExpectRunsWithin("glitch", {{"aces", 1}}, 0.15);
}

// Seeds on which a right wide pose was once refused or misplaced. Seed 3:
// refused as ambiguous (its twin scored 0.93 of it), it was taken only
// when the next scan's wide search landed on it through the odometry
// (1.78 m before). Seed 6: the wide pose had the right heading but lay
// along a corridor from the scan's place; searched again at that heading
// around the predicted position (0.221 m before).
TEST(HarnessEndToEnd, AcesGlitchSeedsOnceLost) {
  ExpectGlitchRunsWithin({{"aces", 3}, {"aces", 6}}, 0.15);
}

// Seed 7: at scan 209 the narrow match had 11% inliers and the wide pose
// 89%, refused as ambiguous; the step kept the odometry's 78 degree error
// as a confident edge (17.1 m). Such a scan now disputes the odometry, and
// the edges in and out of the loss are weak. Then 0.524 m, and seed 61
// 0.565 m: a glitched stretch a degree off brought the robot back to the
// start 3.9 m from it, beyond the 3 m cap on the loop search's radius, and
// no loop closure held the start (the plain log comes back 2.65 m off).
// With the cap at 5 m both are within 0.15 m.
TEST(HarnessEndToEnd, AcesGlitchSeedsBackAtTheStart) {
  ExpectGlitchRunsWithin({{"aces", 7}, {"aces", 61}}, 0.15);
}

// A glitched step's wide search finds the true pose and a half-turned twin
// that scores nearly as well (a corridor, a symmetric room). Judged by the
// way the robot moved from the last matched pose, only the true pose is a
// wheeled base's move: aces seed 12 took the twin (28.5 m before), and in
// csail seed 10 the narrow match fitted a room turned by 77 degrees (4.69 m).
// Aces seed 25: the twin lay 1.9 m back along the corridor at the same
// heading, a backwards move (11.7 m while backwards moves were not judged).
// Intel seed 12, scan 366: the wide search's best and a runner-up turned 91
// degrees from it fit the scan alike (0.44 and 0.54 inliers once refined);
// the next scan, carried to each, fits the runner-up, the true pose (14.9 m
// when the best was taken).
TEST(HarnessEndToEnd, GlitchesNextToTheirTwins) {
  ExpectGlitchRunsWithin({{"aces", 12}, {"csail", 10}, {"aces", 25}, {"intel", 12}}, 0.15);
}

// At a glitch's scan the wide search's best pose and its runner-up, turned
// from each other, fit alike, and the next scan, carried on from each,
// favours the wrong one: a scan that turns into unmapped space fits the
// local map worse than a twin's that looks back at the mapped part. Free
// space tells them apart: the twin puts 17-26% of its points where the local
// map's keyframes saw through, the true pose under 1%. csail seeds 11 and 61
// (11.2 and 10.9 m before), intel seed 45 (8.28 m).
TEST(HarnessEndToEnd, TwinsThatPutWallsInFreeSpace) {
  ExpectGlitchRunsWithin({{"csail", 11}, {"csail", 61}, {"intel", 45}}, 0.15);
}

// csail with its odometry's error three times larger: narrow matches at the
// window's edge, or moves no base makes (a corridor's other place 1.2-1.9 m
// along, at scans 200 and 325), were kept when the wide search offered no
// clearly better pose, though its best or runner-up fitted as well from a
// plausible move. Taking the most plausible of them: 20.3 m -> 0.54 m. The
// rest was scan 38, matched at 36% inliers and so left to the odometry, 22.6
// degrees off: everything before it stood turned, beyond the loop search's
// 20 degree window, and no loop closure re-anchored it. Across such steps
// the loop search now widens by their odometry's uncertainty: 0.098 m.
TEST(HarnessEndToEnd, CsailWithThreeTimesTheOdometryNoise) {
  ExpectRunsWithin("noise3", {{"csail", 1}}, 0.15);
}

// The same widening on csail with half its beams and with 3 cm of range
// noise (0.152 and 0.195 m before it).
TEST(HarnessEndToEnd, CsailWithHalfTheBeamsOrRangeNoise) {
  for (const char* kase : {"half", "range"}) ExpectRunsWithin(kase, {{"csail", 1}}, 0.15);
}

TEST(HarnessEndToEnd, AcesWithEveryOtherScanDropped) {
  ExpectRunsWithin("skip", {{"aces", 1}}, 0.15);
}

// csail seed 43, scan 59: the odometry turned 84 degrees too far, and the
// narrow match, turned 16 degrees more, fitted 61% of the scan (a good
// match there) though 24% of its points lay where the local map had seen
// through; tracked on from it, 5.05 m. A match that leaves the prediction
// and contradicts free space so is now searched wide like a doubted one.
TEST(HarnessEndToEnd, GlitchedTurnMatchedIntoFreeSpace) {
  ExpectGlitchRunsWithin({{"csail", 43}}, 0.15);
}

// csail seed 2 with 3 cm of range noise on top of the glitches, scan 68:
// the wide search found the true pose (0.53 inliers, none in free space),
// but the narrow match, turned 91 degrees at the window's edge, had 0.38
// inliers and the wide pose had to beat them by 0.2. Half of the narrow
// match's points lay where the local map saw through; they no longer count
// for it when the wide pose has next to none there (3.95 m before).
TEST(HarnessEndToEnd, GlitchWithRangeNoiseAgainstAContradictedMatch) {
  ExpectRunsWithin("glitch+range", {{"csail", 2}}, 0.15);
}

// csail with every other scan dropped: steps twice as long reach space the
// local map has not seen, and at scans 163, 185 and 189 the narrow match (at
// its window's edge) or the wide search offered poses 1.7 m and 61 degrees
// from the odometry's prediction, which was within 0.3 m and 8 degrees.
// There the scan put 9-24% of its points where the local map's keyframes
// saw through, at the prediction none: such a pose is now refused and the
// odometry kept (0.760 m before). Not yet within 0.15 m: see docs/frontend.md.
TEST(HarnessEndToEnd, CsailWithEveryOtherScanDropped) {
  ExpectRunsWithin("skip", {{"csail", 1}}, 0.3);
}

// csail's stamps have 6 significant digits (hundreds of scans share one):
// its keyframes pair with the log by scan index, which PREFIX_keyframes.csv
// gives.
TEST(CsailEndToEnd, KeyframesPairWithTheLogByScanIndex) {
  const std::string log_path = cairn::testing::DatasetPath("carmen/csail-corrected.log.gz");
  CAIRN_REQUIRE_DATASET(log_path);
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_csail_e2e";
  std::filesystem::create_directories(dir);
  const std::string prefix = (dir / "csail").string();
  const std::string map_cmd = std::string(CAIRN_TOOL) + " map " + log_path + " -o " + prefix +
                              " --quiet 2> " + prefix + ".stderr";
  ASSERT_EQ(std::system(map_cmd.c_str()), 0) << Slurp(prefix + ".stderr");
  const cairn::frontend::CarmenLog log = cairn::frontend::ReadCarmenLog(log_path);
  cairn::frontend::Trajectory est, ref;
  for (size_t i = 0; i < log.scans.size(); ++i)
    ref.Add(static_cast<double>(i), log.scans[i].reference, static_cast<long>(i));
  std::istringstream csv(Slurp(prefix + "_keyframes.csv"));
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "keyframe,scan,timestamp,x,y,theta");
  std::set<std::string> stamps;
  size_t rows = 0;
  while (std::getline(csv, line)) {
    long keyframe = 0, scan = 0;
    char stamp[64];
    double x = 0, y = 0, theta = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%ld,%ld,%63[^,],%lf,%lf,%lf", &keyframe, &scan, stamp, &x, &y,
                          &theta),
              6)
        << line;
    ASSERT_LT(static_cast<size_t>(scan), log.scans.size());
    EXPECT_EQ(stamp, log.scans[static_cast<size_t>(scan)].timestamp_text);
    est.Add(static_cast<double>(scan), cairn::SE2(x, y, theta), scan);
    stamps.insert(stamp);
    ++rows;
  }
  EXPECT_LT(stamps.size(), rows) << "csail's keyframes were expected to share stamps";
  const cairn::frontend::TrajectoryErrors e = cairn::frontend::EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.matched, rows);
  EXPECT_LE(e.ate_rmse, 0.15);
  // The ATE the tool printed, from the same pairs.
  char printed[16];
  std::snprintf(printed, sizeof printed, "ATE %.3f m", e.ate_rmse);
  EXPECT_NE(Slurp(prefix + ".stderr").find(std::string("result        : ") + printed),
            std::string::npos)
      << Slurp(prefix + ".stderr") << " vs " << printed;
}

}  // namespace
