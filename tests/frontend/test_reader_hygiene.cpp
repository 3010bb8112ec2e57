// The front-end's readers on inputs a user brings: a byte-order mark (plain
// and gzip'd logs, trajectories, calibration pairs), poses no robot has
// (FILE:LINE, not an error far off in the mapper), and lines without end.
#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cairn/calibration/odometry_calibration.h"
#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/graph/graph_io.h"
#include "test_util.h"

namespace cairn::frontend {
namespace {

const std::string kBom = "\xEF\xBB\xBF";

std::string Path(const std::string& name) {
  return (std::filesystem::path(cairn::testing::TempDir()) / name).string();
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = Path(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string WriteGzip(const std::string& name, const std::string& text) {
  const std::string path = Path(name);
  gzFile f = gzopen(path.c_str(), "wb");
  EXPECT_NE(f, nullptr);
  EXPECT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  gzclose(f);
  return path;
}

std::string Flaser(const std::string& pose, double stamp) {
  std::string beams;
  for (int i = 0; i < 180; ++i) beams += " 2.5";
  const std::string t = std::to_string(stamp);
  return "FLASER 180" + beams + " " + pose + " " + pose + " " + t + " h " + t + "\n";
}

// Expects "PATH:LINE: ..." containing `what`.
void ExpectLogError(const std::string& path, size_t line, const std::string& what) {
  try {
    ReadCarmenLog(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind(path + ":" + std::to_string(line) + ": ", 0), 0u)
        << e.what();
    EXPECT_NE(e.message().find(what), std::string::npos) << e.what();
  }
}

TEST(ReaderHygiene, AByteOrderMarkKeepsTheFirstScan) {
  const std::string text = kBom + Flaser("1 2 0.5", 10) + Flaser("1.5 2 0.5", 11);
  EXPECT_EQ(ReadCarmenLog(WriteTemp("bom.log", text)).scans.size(), 2u);
  EXPECT_EQ(ReadCarmenLog(WriteGzip("bom.log.gz", text)).scans.size(), 2u);
}

TEST(ReaderHygiene, PosesBeyondTheSaneRangeNameTheirLogLine) {
  ExpectLogError(WriteTemp("far.log", Flaser("1 2 0.5", 10) + Flaser("1e300 2 0.5", 11)), 2,
                 "pose (1e300, 2) is out of range");
  ExpectLogError(WriteTemp("spin.log", Flaser("1 2 1e17", 10)), 1, "theta 1e17 is out of range");
  ExpectLogError(WriteTemp("odom.log", "ODOM 0 0 0 0 0 0 1 h 1\nODOM 0 -1e300 0 0 0 0 2 h 2\n"), 2,
                 "pose (0, -1e300) is out of range");
  ExpectLogError(WriteGzip("far.log.gz", Flaser("1 2 0.5", 10) + Flaser("1 2 -3e3", 11)), 2,
                 "theta -3e3");
}

TEST(ReaderHygiene, ALineWithoutEndIsAnError) {
  // NUL bytes with no newline, as from /dev/zero: generated here, two bound's worth.
  const std::string zeros(2 * kDefaultMaxLineBytes, '\0');
  ExpectLogError(WriteTemp("zeros.log", zeros), 1, "line longer than 1048576 bytes");
  ExpectLogError(WriteGzip("zeros.log.gz", Flaser("1 2 0.5", 10) + zeros), 2,
                 "line longer than 1048576 bytes");
  // NUL bytes inside a line are binary data, not fields.
  ExpectLogError(WriteTemp("nul.log", std::string("ODOM 0 0 0 0 0 0 1\0 h 1\n", 24)), 1,
                 "binary data");
}

TEST(ReaderHygiene, ATrajectoryWithAByteOrderMark) {
  const std::string path =
      WriteTemp("bom.tum", kBom + "1.0 1 2 0 0 0 0 1\n2.0 2 2 0 0 0 0 1\n");
  const Trajectory t = ReadTrajectory(path);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.stamp_texts[0], "1.0");
  // Sniffed as g2o through the mark too.
  const std::string g2o =
      WriteTemp("bom_graph.txt", kBom + "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
                                        "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\n");
  EXPECT_EQ(ReadTrajectory(g2o).size(), 2u);
}

TEST(ReaderHygiene, CalibrationPairsWithAByteOrderMark) {
  std::istringstream in(kBom + "1 0 0 1.1 0 0\n1 0 0.1 1.1 0 0.1\n");
  const CalibrationData d = ReadCalibrationPairs(in, "p.txt");
  EXPECT_EQ(d.pairs.size(), 2u);
  EXPECT_EQ(d.pairs[0].line, 1u);
}

}  // namespace
}  // namespace cairn::frontend
