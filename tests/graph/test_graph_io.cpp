// Reading and writing g2o and TORO files: every tag, exact round trips, and
// every kind of bad input answered with FILE:LINE.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/simulate.h"
#include "graph/parse_helpers.h"
#include "test_util.h"

namespace cairn {
namespace {

using testing::ExpectError;
using testing::Parse;

const char* kSE2 =
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1.5 0.25 0.1\n"
    "VERTEX_SE2 2 2.5 0.5 3.0\n"
    "FIX 0\n"
    "EDGE_SE2 0 1 1.4 0.2 0.12 500 10 1 400 2 3000\n"
    "EDGE_SE2 1 2 1.0 0.3 2.9 500 0 0 500 0 5000\n"
    "EDGE_SE2 0 2 2.4 0.7 3.1 50 0 0 50 0 500\n"
    "EDGE_PRIOR_SE2 1 1.5 0.25 0.1 100 0 0 100 0 100\n";

const char* kSE3 =
    "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
    "VERTEX_SE3:QUAT 1 1 0.1 -0.2 0.01 0.02 0.03 0.99930\n"
    "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 "
    "100 1 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n"
    "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n"
    "EDGE_SE3_PRIOR 1 0 1 0.1 -0.2 0 0 0 1 "
    "10 0 0 0 0 0 10 0 0 0 0 10 0 0 0 40 0 0 40 0 40\n";

TEST(ReadG2o, SE2Tags) {
  const PoseGraph g = Parse(kSE2);
  EXPECT_EQ(g.dimension(), 2);
  ASSERT_EQ(g.vertices().size(), 3u);
  EXPECT_TRUE(g.vertex(0).fixed);
  EXPECT_FALSE(g.vertex(1).fixed);
  EXPECT_DOUBLE_EQ(g.vertex(1).x[2], 0.1);
  ASSERT_EQ(g.edges().size(), 4u);
  EXPECT_EQ(g.CountEdges(EdgeKind::kOdometry), 2u);
  EXPECT_EQ(g.CountEdges(EdgeKind::kLoopClosure), 1u);
  EXPECT_EQ(g.CountEdges(EdgeKind::kPrior), 1u);
  // Upper triangle row by row: (xx, xy, xt, yy, yt, tt).
  const Matrix6d& info = g.edges()[0].information;
  EXPECT_EQ(info(0, 1), 10);
  EXPECT_EQ(info(1, 0), 10);
  EXPECT_EQ(info(0, 2), 1);
  EXPECT_EQ(info(1, 1), 400);
  EXPECT_EQ(info(1, 2), 2);
  EXPECT_EQ(info(2, 2), 3000);
  EXPECT_EQ(g.edges()[3].from, 1);
}

TEST(ReadG2o, SE3TagsAndPrior) {
  const PoseGraph g = Parse(kSE3);
  EXPECT_EQ(g.dimension(), 3);
  ASSERT_EQ(g.edges().size(), 2u);
  EXPECT_TRUE(g.edges()[1].IsPrior());
  EXPECT_EQ(g.edges()[0].information(0, 1), 1);
  EXPECT_EQ(g.edges()[0].information(3, 3), 400);
  // The slightly off-unit quaternion of vertex 1 was normalised.
  const auto& x = g.vertex(1).x;
  EXPECT_NEAR(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6], 1.0, 1e-15);
}

TEST(ReadG2o, RoundTripIsExact) {
  for (const char* text : {kSE2, kSE3}) {
    const PoseGraph a = Parse(text);
    std::ostringstream first;
    WriteG2o(a, first);
    const PoseGraph b = Parse(first.str());
    std::ostringstream second;
    WriteG2o(b, second);
    EXPECT_EQ(first.str(), second.str());
    ASSERT_EQ(a.vertices().size(), b.vertices().size());
    for (size_t i = 0; i < a.vertices().size(); ++i) {
      EXPECT_EQ(a.vertices()[i].id, b.vertices()[i].id);
      EXPECT_EQ(a.vertices()[i].fixed, b.vertices()[i].fixed);
      EXPECT_EQ(0, std::memcmp(a.vertices()[i].x.data(), b.vertices()[i].x.data(),
                               sizeof(PoseParams)));
    }
    ASSERT_EQ(a.edges().size(), b.edges().size());
    for (size_t k = 0; k < a.edges().size(); ++k) {
      EXPECT_EQ(a.edges()[k].kind, b.edges()[k].kind);
      EXPECT_EQ(a.edges()[k].z, b.edges()[k].z);
      EXPECT_EQ(a.edges()[k].information, b.edges()[k].information);
    }
    EXPECT_EQ(Chi2(a), Chi2(b));
  }
}

TEST(ReadG2o, RoundTripKeepsAwkwardDoubles) {
  PoseGraph g(2);
  g.AddVertex(0, PoseParams{0.1 + 0.2, 1e-300, -3.141592653589793, 0, 0, 0, 0});
  g.AddVertex(1, PoseParams{1.0 / 3.0, 123456789.123456789, 2.718281828459045, 0, 0, 0, 0});
  Edge e;
  e.from = 0;
  e.to = 1;
  e.z = {std::nextafter(1.0, 2.0), 0, 0, 0, 0, 0, 0};
  Eigen::Matrix3d info;
  info << 1.0 / 7.0, 1e-17, 0, 1e-17, 2.0 / 3.0, 0, 0, 0, 1e5;
  e.information.SetTopLeft(info);
  g.AddEdge(e);
  std::ostringstream out;
  WriteG2o(g, out);
  const PoseGraph r = Parse(out.str());
  EXPECT_EQ(r.vertex(0).x, g.vertex(0).x);
  EXPECT_EQ(r.vertex(1).x, g.vertex(1).x);
  EXPECT_EQ(r.edges()[0].z, g.edges()[0].z);
  EXPECT_EQ(r.edges()[0].information, g.edges()[0].information);
}

TEST(ReadToro, TwoDimensionalInformationOrder) {
  // TORO: (xx, xy, yy, tt, xt, yt).
  const PoseGraph g = Parse(
      "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\n"
      "EDGE2 0 1 1 0 0 11 1 22 33 2 3\n");
  const Matrix6d& info = g.edges()[0].information;
  EXPECT_EQ(info(0, 0), 11);
  EXPECT_EQ(info(0, 1), 1);
  EXPECT_EQ(info(1, 1), 22);
  EXPECT_EQ(info(2, 2), 33);
  EXPECT_EQ(info(0, 2), 2);
  EXPECT_EQ(info(2, 0), 2);
  EXPECT_EQ(info(1, 2), 3);
}

TEST(ReadToro, ThreeDimensional) {
  const PoseGraph g = Parse(
      "VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 1 0 0 0 0 1.5707963267948966\n"
      "EDGE3 0 1 1 0 0 0 0 1.5707963267948966 "
      "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n");
  EXPECT_EQ(g.dimension(), 3);
  const SE3 p = ToSE3(g.vertex(1).x);
  EXPECT_NEAR(Eigen::AngleAxisd(p.rotation()).angle(), M_PI / 2, 1e-12);
  // Rotation information scaled for g2o's half-angle error.
  EXPECT_EQ(g.edges()[0].information(3, 3), 4);
  EXPECT_EQ(g.edges()[0].information(0, 0), 1);
  EXPECT_NEAR(Chi2(g), 0, 1e-20);
}

// What WriteToro wrote, read back.
PoseGraph ToroRoundTrip(const PoseGraph& g) {
  std::ostringstream out;
  WriteToro(g, out);
  return Parse(out.str());
}

// The same ids, fixed vertices and edges, and the same chi2 to the last digits
// an Euler-angle detour leaves.
void ExpectSameGraph(const PoseGraph& a, const PoseGraph& b, double chi2_tolerance) {
  ASSERT_EQ(a.dimension(), b.dimension());
  ASSERT_EQ(a.vertices().size(), b.vertices().size());
  ASSERT_EQ(a.edges().size(), b.edges().size());
  for (size_t k = 0; k < a.vertices().size(); ++k) {
    EXPECT_EQ(a.vertices()[k].id, b.vertices()[k].id);
    EXPECT_EQ(a.vertices()[k].fixed, b.vertices()[k].fixed);
  }
  for (size_t k = 0; k < a.edges().size(); ++k) {
    EXPECT_EQ(a.edges()[k].from, b.edges()[k].from);
    EXPECT_EQ(a.edges()[k].to, b.edges()[k].to);
    EXPECT_EQ(a.edges()[k].kind, b.edges()[k].kind);
  }
  EXPECT_NEAR(Chi2(b), Chi2(a), chi2_tolerance * Chi2(a));
}

TEST(WriteToro, ReadsBackToTheSameGraphAndChi2) {
  for (int dim : {2, 3}) {
    SimulationOptions o;
    o.dimension = dim;
    o.poses = 300;
    o.nodes_per_lap = 30;
    o.seed = 11;
    const PoseGraph g = Simulate(o).noisy;
    ASSERT_GT(Chi2(g), 0);
    const PoseGraph back = ToroRoundTrip(g);
    ExpectSameGraph(g, back, 1e-9);
    for (size_t k = 0; k < g.vertices().size(); ++k)
      for (int i = 0; i < g.ParameterSize(); ++i)
        EXPECT_NEAR(std::abs(back.vertices()[k].x[i]), std::abs(g.vertices()[k].x[i]), 1e-9);
  }
}

TEST(WriteToro, WritesTorosTagsAndInformationOrder) {
  const PoseGraph g = Parse(
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0.5\nFIX 0\n"
      "EDGE_SE2 0 1 1 0 0.5 11 1 2 22 3 33\n");
  std::ostringstream out;
  WriteToro(g, out);
  EXPECT_EQ(out.str(),
            "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0.5\nFIX 0\n"
            "EDGE2 0 1 1 0 0.5 11 1 22 33 2 3\n");
  EXPECT_TRUE(ToroRoundTrip(g).vertex(0).fixed);
  // 3D: roll-pitch-yaw, and the weights of TORO's angle errors (a quarter of g2o's).
  const PoseGraph g3 = ToroRoundTrip(
      Parse("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
            "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.70710678118654757 0.70710678118654757\n"
            "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 "
            "100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n"));
  EXPECT_DOUBLE_EQ(g3.edges()[0].information(3, 3), 400);
  EXPECT_NEAR(ToSE3(g3.vertex(1).x).rotation().z(), std::sqrt(0.5), 1e-15);
}

TEST(WriteToro, RefusesWhatTorosFormatCannotHold) {
  const PoseGraph with_prior = Parse(kSE2);
  EXPECT_NE(ToroRefusal(with_prior).find("no prior edges"), std::string::npos);
  std::ostringstream out;
  EXPECT_THROW(WriteToro(with_prior, out), std::invalid_argument);
  EXPECT_EQ(out.str(), "");
  ReadOptions keep;
  keep.keep_unknown = true;
  const PoseGraph kept = Parse("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nROBOTLASER1 1 2\n"
                               "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", keep);
  EXPECT_NE(ToroRefusal(kept).find("verbatim"), std::string::npos);
  const PoseGraph landmarks = Parse("VERTEX_SE2 0 0 0 0\nVERTEX_XY 5 1 2\nEDGE_SE2_XY 0 5 1 2 1 0 1\n");
  EXPECT_NE(ToroRefusal(landmarks).find("no landmarks (1 here)"), std::string::npos);
  EXPECT_EQ(ToroRefusal(Parse("VERTEX2 0 0 0 0\n")), "");
}

TEST(GraphFormat, ByTheNamesExtensionInAnyCase) {
  EXPECT_EQ(GraphFormatOf("a/b.g2o"), GraphFormat::kG2o);
  EXPECT_EQ(GraphFormatOf("B.G2O"), GraphFormat::kG2o);
  EXPECT_EQ(GraphFormatOf("x.graph"), GraphFormat::kToro);
  EXPECT_EQ(GraphFormatOf("x.Graph"), GraphFormat::kToro);
  EXPECT_FALSE(GraphFormatOf("x.txt"));
  EXPECT_FALSE(GraphFormatOf("graph"));
  EXPECT_FALSE(GraphFormatOf("x.g2o.bak"));
}

// The shared files through TORO and back: the same chi2 (the Euler-angle
// detour costs last bits only).
TEST(WriteToro, SharedFilesReadBackToTheSameChi2) {
  for (const char* file : {"g2o/2d/intel.g2o", "g2o/3d/sphere2500.g2o", "g2o/3d/parking-garage.g2o"}) {
    const std::string path = cairn::testing::DatasetPath(file);
    CAIRN_REQUIRE_DATASET(path);
    const PoseGraph g = ReadGraph(path);
    ExpectSameGraph(g, ToroRoundTrip(g), 1e-6);
  }
}

// g2o's EdgeSE3XYZPrior: error t - z on the translation alone (a GPS fix).
TEST(ReadG2o, TranslationPriorIsAPositionOnlyPrior) {
  const std::string text =
      "VERTEX_SE3:QUAT 0 1 2 3 0 0 0.38268343236508978 0.92387953251128674\n"
      "PARAMS_SE3OFFSET 7 0 0 0 0 0 0 1\n"
      "EDGE_SE3_XYZPRIOR 0 7 1.5 2 2 4 1 0 9 0 16\n";
  const PoseGraph g = Parse(text);
  ASSERT_EQ(g.edges().size(), 1u);
  const Edge& e = g.edges()[0];
  EXPECT_EQ(e.kind, EdgeKind::kPrior);
  EXPECT_TRUE((e.information.bottomRightCorner<3, 3>().isZero(0)));
  // e = (-0.5, 0, 1): 4 * 0.25 + 2 * (-0.5 * 0) * 1 + 9 * 0 + 16 * 1, whatever the rotation.
  EXPECT_NEAR(Chi2(g), 4 * 0.25 + 16, 1e-12);
  std::ostringstream out;
  WriteG2o(g, out);
  EXPECT_NE(out.str().find("EDGE_SE3_XYZPRIOR 0 7 1.5 2 2 4 1 0 9 0 16\n"), std::string::npos)
      << out.str();
  EXPECT_EQ(Chi2(Parse(out.str())), Chi2(g));
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3_XYZPRIOR 0 3 1 2 3 1 0 0 1 0 1\n", 2,
              "no PARAMS_SE3OFFSET");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nPARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n"
              "EDGE_SE3_XYZPRIOR 0 0 1 2 3 1 0 0 1 0\n", 3, "");
}

TEST(ReadG2o, EdgesOnlyGetVerticesFromSpanningTree) {
  const PoseGraph g = Parse(
      "EDGE_SE2 5 6 1 0 1.5707963267948966 1 0 0 1 0 1\n"
      "EDGE_SE2 6 7 1 0 0 1 0 0 1 0 1\n");
  ASSERT_EQ(g.vertices().size(), 3u);
  EXPECT_EQ(g.vertex(5).x[0], 0);
  EXPECT_NEAR(g.vertex(7).x[0], 1, 1e-15);
  EXPECT_NEAR(g.vertex(7).x[1], 1, 1e-15);
  EXPECT_NEAR(Chi2(g), 0, 1e-25);
}

TEST(ReadG2o, UnknownTagsFailUnlessKept) {
  const std::string text = std::string(kSE2) + "ROBOTLASER1 1 2 3\nROBOTLASER1 4 5\nFOO\n";
  ExpectError(text, 9, "unknown tag 'ROBOTLASER1'");
  ReadOptions options;
  ExpectError(text, 9, "unknown tag 'ROBOTLASER1'", options);
  options.keep_unknown = true;
  const PoseGraph g = Parse(text, options);
  EXPECT_EQ(g.edges().size(), 4u);
  ASSERT_EQ(g.verbatim_lines().size(), 3u);
  EXPECT_EQ(g.verbatim_lines()[2].text, "FOO");
}

TEST(ReadG2o, CommentsAndBlankLines) {
  const PoseGraph g = Parse("# a graph\n\nVERTEX_SE2 0 0 0 0  # origin\n  \n");
  EXPECT_EQ(g.vertices().size(), 1u);
}

TEST(ReadG2oErrors, EveryKindOfBadInput) {
  const std::string v01 = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  ExpectError("VERTEX_SE2 0 0 0\n", 1, "needs 4 fields, found 3");
  ExpectError("VERTEX_SE2 0 0 0 0 9\n", 1, "takes 4 fields, found 5");
  ExpectError(v01 + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", 3, "needs 11 fields");
  ExpectError("VERTEX_SE2 0 abc 0 0\n", 1, "expected a number for x, found 'abc'");
  ExpectError("VERTEX_SE2 0 1.5x 0 0\n", 1, "expected a number");
  ExpectError("VERTEX_SE2 0 nan 0 0\n", 1, "NaN");
  ExpectError("VERTEX_SE2 0 0 inf 0\n", 1, "out of range");
  ExpectError("VERTEX_SE2 0 1e999 0 0\n", 1, "out of range");
  ExpectError("VERTEX_SE2 -1 0 0 0\n", 1, "out of range");
  ExpectError("VERTEX_SE2 99999999999 0 0 0\n", 1, "out of range");
  ExpectError("VERTEX_SE2 1.5 0 0 0\n", 1, "expected a vertex id");
  ExpectError(v01 + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 -1\n", 3, "indefinite");
  ExpectError(v01 + "EDGE_SE2 0 1 1 0 0 1 5 0 1 0 1\n", 3, "--repair-information");
  ExpectError(v01 + "EDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n", 3, "information matrix is zero");
  ExpectError(v01 + "EDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n", 3, "vertex 7, which does not exist");
  ExpectError(v01 + "EDGE_SE2 1 1 1 0 0 1 0 0 1 0 1\n", 3, "to itself");
  ExpectError(v01 + "VERTEX_SE2 1 0 0 0\n", 3, "duplicate vertex id 1");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0\n", 1, "zero quaternion");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 2\n", 1, "far from unit length");
  ExpectError(v01 + "VERTEX_SE3:QUAT 2 0 0 0 0 0 0 1\n", 3, "cannot be mixed");
  ExpectError("", 1, "empty file");
  ExpectError("# only a comment\n\n", 2, "empty file");
  ExpectError(std::string("VERTEX_SE2 0 0 0 0\n\x7f" "ELF\x01\x02\x00\x00junk", 26), 2,
              "binary data");
  ExpectError(v01 + "FIX 9\n", 3, "FIX names vertex 9");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
              "EDGE_SE3_PRIOR 0 3 0 0 0 0 0 0 1 "
              "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n",
              2, "no PARAMS_SE3OFFSET");
}

// The reader holds pending edges in chunks of 131,072: more edges than two
// chunks must all arrive, in file order, and an error past the first chunk
// must still name its own line.
TEST(ReadG2o, EdgesBeyondOnePendingChunk) {
  const int n = 300000;
  std::string text;
  text.reserve(size_t{n} * 48);
  char buf[96];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof buf, "VERTEX_SE2 %d %d 0 0\n", i, i);
    text += buf;
  }
  for (int i = 0; i + 1 < n; ++i) {
    std::snprintf(buf, sizeof buf, "EDGE_SE2 %d %d 1 0 %.17g %d 0 0 %d 0 1\n", i, i + 1, i * 1e-6,
                  1 + i % 7, 1 + i % 5);
    text += buf;
  }
  const PoseGraph g = Parse(text);
  ASSERT_EQ(g.vertices().size(), size_t{n});
  ASSERT_EQ(g.edges().size(), size_t{n - 1});
  for (int i = 0; i + 1 < n; ++i) {
    const Edge& e = g.edges()[i];
    ASSERT_EQ(e.from, i);
    ASSERT_EQ(e.to, i + 1);
    ASSERT_EQ(e.z[2], i * 1e-6);
    ASSERT_EQ(e.information(0, 0), 1 + i % 7);
    ASSERT_EQ(e.information(1, 1), 1 + i % 5);
  }
  // A missing endpoint on the last line, well into the third chunk.
  const std::string bad = text + "EDGE_SE2 5 300001 1 0 0 1 0 0 1 0 1\n";
  ExpectError(bad, 2 * n, "edge to vertex 300001, which does not exist");
}

TEST(ReadG2oErrors, MissingFileAndDirectory) {
  EXPECT_THROW(ReadGraph("/nonexistent/graph.g2o"), std::runtime_error);
  EXPECT_THROW(ReadGraph(std::filesystem::path(cairn::testing::TempDir()).string()), std::runtime_error);
}

TEST(WriteG2o, AtomicWriteLeavesNoHalfFile) {
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) / "cairn_atomic_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "out.g2o").string();
  std::filesystem::remove(path);
  EXPECT_THROW(WriteFileAtomically(path,
                                   [](std::ostream& out) {
                                     out << "VERTEX_SE2 0 0 0 0\n";
                                     throw std::runtime_error("interrupted");
                                   }),
               std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(dir)) << "temporary file left behind";
  WriteG2o(Parse(kSE2), path);
  EXPECT_EQ(ReadGraph(path).edges().size(), 4u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn
