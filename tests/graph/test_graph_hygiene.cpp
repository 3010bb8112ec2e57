// The graph reader on inputs a user brings: a byte-order mark, headings and
// coordinates no pose has, and tags cairn does not know (an error, or kept
// verbatim and written back in place).
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "cairn/graph/graph_io.h"
#include "graph/parse_helpers.h"
#include "test_util.h"

namespace cairn {
namespace {

using testing::ExpectError;
using testing::Parse;

std::string Written(const PoseGraph& g) {
  std::ostringstream out;
  WriteG2o(g, out);
  return out.str();
}

const std::string kBom = "\xEF\xBB\xBF";
const std::string kInfo = " 100 0 0 100 0 100\n";

TEST(GraphHygiene, AByteOrderMarkKeepsTheFirstEdgeOfAnEdgesOnlyFile) {
  const PoseGraph g = Parse(kBom + "EDGE_SE2 0 1 1 0 0" + kInfo + "EDGE_SE2 1 2 1 0 0" + kInfo);
  ASSERT_EQ(g.edges().size(), 2u);
  EXPECT_EQ(g.edges()[0].from, 0);
  EXPECT_EQ(g.vertices().size(), 3u);
}

TEST(GraphHygiene, AByteOrderMarkBeforeAVertex) {
  const PoseGraph g =
      Parse(kBom + "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0" + kInfo);
  EXPECT_EQ(g.vertices().size(), 2u);
  EXPECT_EQ(g.edges().size(), 1u);
}

TEST(GraphHygiene, HeadingsBeyondTheSaneRangeAreErrors) {
  const std::string v01 = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 1e17\n", 2, "theta 1e+17 rad is out of range");
  ExpectError(v01 + "EDGE_SE2 0 1 1 0 -1e17" + kInfo, 3, "dtheta -1e+17 rad is out of range");
  ExpectError(v01 + "EDGE2 0 1 1 0 1001 100 0 100 100 0 0\n", 3, "dtheta 1001 rad");
  ExpectError(v01 + "EDGE_PRIOR_SE2 1 1 0 2e3" + kInfo, 3, "theta 2000 rad");
  ExpectError("VERTEX3 0 0 0 0 0 1e17 0\n", 1, "an angle 1e+17 rad is out of range");
  ExpectError("VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 0 0 0 0 0 0\n"
              "EDGE3 0 1 1 0 0 0 0 -5e3 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n",
              3, "an angle -5000 rad");
  // Unnormalised headings a real file may hold are still read.
  EXPECT_NO_THROW(Parse("VERTEX_SE2 0 0 0 999.5\nVERTEX_SE2 1 1 0 -12.5\nEDGE_SE2 0 1 1 0 7" + kInfo));
}

TEST(GraphHygiene, CoordinatesBeyondTheSaneRangeAreErrors) {
  ExpectError("VERTEX_SE2 0 1e300 0 0\n", 1, "coordinate 1e+300 is out of range");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 0 -2e9 0" + kInfo, 3,
              "coordinate -2e+09");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 1e300 0 0 0 1\n", 1, "coordinate 1e+300");
  ExpectError("VERTEX3 0 0 1e300 0 0 0 0\n", 1, "coordinate 1e+300");
  // Non-finite numbers were refused before and still are.
  ExpectError("VERTEX_SE2 0 nan 0 0\n", 1, "NaN");
  ExpectError("VERTEX_SE2 0 0 inf 0\n", 1, "out of range");
  ExpectError("VERTEX_SE2 0 0 0 1e400\n", 1, "out of range");
}

TEST(GraphHygiene, AnUnknownTagIsAnErrorNamingItsLineAndTag) {
  const std::string text = "VERTEX_SE2 0 0 0 0\nVERTEX_LINE2D 7 1 2\nVERTEX_SE2 1 1 0 0\n";
  ExpectError(text, 2, "unknown tag 'VERTEX_LINE2D'");
  ReadOptions keep_nothing;  // the default options: the same answer
  ExpectError(text, 2, "unknown tag 'VERTEX_LINE2D'", keep_nothing);
}

TEST(GraphHygiene, KeptUnknownLinesRoundTripInPlace) {
  const std::string text =
      "TAG_BEFORE_ALL 1\n"
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_LINE2D 7 1 2   # spacing and comment kept\n"
      "VERTEX_SE2 1 1 0 0\n"
      "AFTER_VERTICES x\n"
      "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\n"
      "EDGE_SE2_LINE2D 0 7 1 2 1 0 1\n"
      "EDGE_SE2 1 0 -1 0 0 100 0 0 100 0 100\n"
      "AT_THE_END\n";
  ReadOptions keep;
  keep.keep_unknown = true;
  const PoseGraph g = Parse(text, keep);
  ASSERT_EQ(g.verbatim_lines().size(), 5u);
  EXPECT_EQ(g.vertices().size(), 2u);
  EXPECT_EQ(g.edges().size(), 2u);
  EXPECT_EQ(Written(g), text);
  // And again from what was written.
  EXPECT_EQ(Written(Parse(Written(g), keep)), text);
}

TEST(GraphHygiene, KeptLinesOfAnEdgesOnlyFileStayAmongTheEdges) {
  ReadOptions keep;
  keep.keep_unknown = true;
  const PoseGraph g =
      Parse("EDGE_SE2 0 1 1 0 0" + kInfo + "MARK here\nEDGE_SE2 1 2 1 0 0" + kInfo, keep);
  const std::string out = Written(g);
  const size_t mark = out.find("MARK here\n");
  ASSERT_NE(mark, std::string::npos) << out;
  EXPECT_LT(out.find("EDGE_SE2 0 1"), mark);
  EXPECT_GT(out.find("EDGE_SE2 1 2"), mark);
  EXPECT_LT(out.rfind("VERTEX_SE2"), mark);
}

TEST(GraphHygiene, TheSharedFilesStillRead) {
  for (const char* f : {"g2o/2d/intel.g2o", "g2o/2d/MIT.g2o", "g2o/2d/CSAIL.g2o",
                        "g2o/2d/manhattan.g2o", "g2o/2d/city10000.g2o", "g2o/3d/tinyGrid3D.g2o",
                        "g2o/3d/smallGrid3D.g2o", "g2o/3d/sphere2500.g2o",
                        "g2o/3d/parking-garage.g2o", "g2o/3d/sphere_bignoise_vertex3.g2o"}) {
    const std::string path = testing::DatasetPath(f);
    CAIRN_REQUIRE_DATASET(path);
    const PoseGraph g = ReadGraph(path);
    EXPECT_GT(g.edges().size(), 0u) << f;
    EXPECT_TRUE(g.verbatim_lines().empty()) << f;
  }
}

}  // namespace
}  // namespace cairn
