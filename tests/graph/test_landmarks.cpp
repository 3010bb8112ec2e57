// Point landmarks in the graph model and its g2o files: every tag read and
// written back, chi2 against a hand computation, the reader's refusals,
// components tied through landmarks, and every initialiser placing them.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_graph.h"
#include "parse_helpers.h"

namespace cairn {
namespace {

using testing::ExpectError;
using testing::Parse;

const char* k2D =
    "VERTEX_SE2 0 1 2 1.5707963267948966\n"
    "VERTEX_SE2 1 2 2 1.5707963267948966\n"
    "VERTEX_XY 7 1 4\n"
    "FIX 7\n"
    "EDGE_SE2 0 1 0 -1 0 10 0 0 10 0 10\n"
    "EDGE_SE2_XY 0 7 1.5 0.5 2 0.5 1\n"
    "EDGE_PRIOR_XY 7 1.25 4 4 0 1\n";

// Pose 1 at (1, 0, 0) turned 90 degrees about z; offset 1 at (0, 1, 0)
// turned 90 degrees about x: the sensor sits at the origin.
const char* k3D =
    "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n"
    "PARAMS_SE3OFFSET 1 0 1 0 0.70710678118654757 0 0 0.70710678118654757\n"
    "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.70710678118654757 0.70710678118654757\n"
    "VERTEX_SE3:QUAT 2 2 0 0 0 0 0.70710678118654757 0.70710678118654757\n"
    "VERTEX_TRACKXYZ 9 0 2 1\n"
    "EDGE_SE3:QUAT 1 2 0 -1 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"
    "EDGE_SE3_TRACKXYZ 1 9 1 1.5 0.5 0 2 0.5 0 1 0 3\n"
    "EDGE_SE3_TRACKXYZ 2 9 0 2 1 1 1 0 0 1 0 1\n"
    "EDGE_POINTXYZ_PRIOR 9 0 2 0.5 1 0 0 1 0 2\n";

void ExpectSameGraph(const PoseGraph& a, const PoseGraph& b) {
  ASSERT_EQ(a.vertices().size(), b.vertices().size());
  ASSERT_EQ(a.edges().size(), b.edges().size());
  for (size_t i = 0; i < a.vertices().size(); ++i) {
    const Vertex &va = a.vertices()[i], &vb = b.vertices()[i];
    EXPECT_EQ(va.id, vb.id);
    EXPECT_EQ(va.landmark, vb.landmark);
    EXPECT_EQ(va.fixed, vb.fixed);
    EXPECT_EQ(va.x, vb.x);
  }
  for (size_t k = 0; k < a.edges().size(); ++k) {
    const Edge &ea = a.edges()[k], &eb = b.edges()[k];
    EXPECT_EQ(ea.kind, eb.kind);
    EXPECT_EQ(ea.from, eb.from);
    EXPECT_EQ(ea.to, eb.to);
    EXPECT_EQ(ea.offset, eb.offset);
    EXPECT_EQ(ea.z, eb.z);
    EXPECT_EQ(ea.information, eb.information);
  }
  ASSERT_EQ(a.offsets().size(), b.offsets().size());
  for (const auto& [id, o] : a.offsets())
    EXPECT_EQ(o.ToVector(), b.offset(id).ToVector()) << "offset " << id;
}

std::string Written(const PoseGraph& g) {
  std::ostringstream out;
  WriteG2o(g, out);
  return out.str();
}

TEST(Landmarks, EveryTagRoundTrips) {
  for (const char* text : {k2D, k3D}) {
    const PoseGraph g = Parse(text);
    const std::string out = Written(g);
    ExpectSameGraph(g, Parse(out));
    // g2o's own tags, one line per vertex and edge.
    std::istringstream expected(text), written(out);
    std::string a, b;
    while (std::getline(expected, a) && std::getline(written, b))
      EXPECT_EQ(a.substr(0, a.find(' ')), b.substr(0, b.find(' ')));
  }
  const PoseGraph g2 = Parse(k2D), g3 = Parse(k3D);
  EXPECT_EQ(g2.CountLandmarks(), 1u);
  EXPECT_EQ(g2.CountEdges(EdgeKind::kLandmark), 1u);
  EXPECT_EQ(g2.CountEdges(EdgeKind::kLandmarkPrior), 1u);
  EXPECT_TRUE(g2.vertex(7).fixed);
  EXPECT_EQ(g3.CountLandmarks(), 1u);
  EXPECT_EQ(g3.CountEdges(EdgeKind::kLandmark), 2u);
  EXPECT_EQ(g3.edges()[1].offset, 1);
}

// By hand, k2D: pose 0 at (1, 2) facing +y sees (1, 4) at (2, 0); z = (1.5,
// 0.5) leaves e = (0.5, -0.5), e^T [2 .5; .5 1] e = 0.5 - 0.25 + 0.25 = 0.5.
// The prior: e = (-0.25, 0), 4 * 0.0625 = 0.25. Odometry: exact, 0.
TEST(Landmarks, ChiSquaredMatchesAHandComputation2D) {
  const PoseGraph g = Parse(k2D);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[0]), 0.0, 1e-20);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[1]), 0.5, 1e-12);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[2]), 0.25, 1e-12);
  EXPECT_NEAR(Chi2(g), 0.75, 1e-12);
}

// By hand, k3D: pose 1 * offset 1 puts the sensor at (1,0,0) + Rz(90)(0,1,0)
// = 0, turned Rz(90) Rx(90); it sees (0,2,1) at Rx(-90) Rz(-90) (0,2,1) =
// Rx(-90) (2,0,1) = (2,1,0). z = (1.5,0.5,0): e = (0.5,0.5,0), e^T Omega e =
// 0.5 + 0.25 + 0.25 = 1. Pose 2 (identity offset) sees (0,2,1) - (2,0,0) =
// (-2,2,1) as Rz(-90) of it, (2,2,1): e = (0,1,0), 1. Prior: (0,0,0.5), 0.5.
TEST(Landmarks, ChiSquaredMatchesAHandComputation3D) {
  const PoseGraph g = Parse(k3D);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[0]), 0.0, 1e-20);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[1]), 1.0, 1e-12);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[2]), 1.0, 1e-12);
  EXPECT_NEAR(EdgeChi2(g, g.edges()[3]), 0.5, 1e-12);
}

TEST(Landmarks, ReaderRefusesWrongSortsAndMissingOffsets) {
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2_XY 0 1 1 1 1 0 1\n", 3,
              "a pose, not a landmark");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", 3,
              "a landmark, not a pose");
  ExpectError("VERTEX_XY 1 0 0\nEDGE_PRIOR_SE2 1 0 0 0 1 0 0 1 0 1\n", 2, "a landmark, not a pose");
  ExpectError("VERTEX_SE2 0 0 0 0\nEDGE_PRIOR_XY 0 0 0 1 0 1\n", 2, "a pose, not a landmark");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_TRACKXYZ 1 0 0 0\n"
              "EDGE_SE3_TRACKXYZ 0 1 4 1 1 1 1 0 0 1 0 1\n",
              3, "no PARAMS_SE3OFFSET");
  ExpectError("VERTEX_XY 1 0\n", 1, "needs 3 fields");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\nEDGE_SE2_XY 0 1 1 1 1 0 -1\n", 3,
              "information matrix is indefinite");
  // A singular observation (nothing along y) is taken, as for poses.
  EXPECT_EQ(Parse("VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\nEDGE_SE2_XY 0 1 1 1 1 0 0\n").edges().size(), 1u);
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_TRACKXYZ 1 0 0 0\n", 2, "cannot be mixed");
  // Without vertices, an id both pose and landmark.
  ExpectError("EDGE_SE2_XY 0 1 1 1 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n", 2,
              "used as a pose here and as a landmark on line 1");
}

// Two odometry chains that share only landmarks are one component, given
// one gauge (a pose), and the spanning tree of a file without vertices
// places each landmark from its first observation.
TEST(Landmarks, PosesTiedThroughLandmarksAreOneComponent) {
  const PoseGraph g = Parse(
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 5 6 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2_XY 1 10 2 1 1 0 1\n"
      "EDGE_SE2_XY 5 10 0.5 1 1 0 1\n"
      "EDGE_SE2_XY 6 11 1 -1 1 0 1\n"
      "EDGE_SE2_XY 0 11 3 -1 1 0 1\n");
  ASSERT_EQ(ConnectedComponents(g).size(), 1u);
  EXPECT_EQ(ConnectedComponents(g, /*through_landmarks=*/false).size(), 4u);
  EXPECT_TRUE(g.vertex(10).landmark);
  EXPECT_FALSE(g.vertex(5).landmark);
  // Pose 1 chained from 0 at (1, 0, 0): landmark 10 at (3, 1).
  EXPECT_NEAR(g.vertex(10).x[0], 3.0, 1e-12);
  EXPECT_NEAR(g.vertex(10).x[1], 1.0, 1e-12);
  // Landmark 11 first seen from pose 6, chained from 5 (its own root at 0).
  EXPECT_NEAR(g.vertex(11).x[0], 2.0, 1e-12);
  EXPECT_NEAR(g.vertex(11).x[1], -1.0, 1e-12);
}

void ExpectLandmarksAtFirstObservation(const PoseGraph& g) {
  std::vector<bool> seen(g.vertices().size(), false);
  for (const Edge& e : g.edges()) {
    if (e.kind != EdgeKind::kLandmark || seen[g.VertexIndex(e.to)]) continue;
    seen[g.VertexIndex(e.to)] = true;
    const Eigen::Vector3d p = ObservedPoint(g, e, g.vertex(e.from).x);
    for (int k = 0; k < g.dimension(); ++k) EXPECT_NEAR(g.vertex(e.to).x[k], p[k], 1e-9);
  }
}

TEST(Landmarks, EveryInitialiserPlacesThem) {
  for (const char* text : {k2D, k3D}) {
    for (InitMethod m : {InitMethod::kOdometry, InitMethod::kSpanningTree, InitMethod::kChordal}) {
      PoseGraph g = Parse(text);
      for (Vertex& v : g.vertices()) v.fixed = false;
      for (Vertex& v : g.vertices())
        if (v.landmark) v.x[0] = 1e3;  // far from any observation
      Initialize(g, m);
      SCOPED_TRACE(ToString(m));
      ExpectLandmarksAtFirstObservation(g);
      EXPECT_LT(Chi2(g), 1e3);
    }
  }
}

TEST(Landmarks, FixedLandmarkStaysAndGraphChecksSorts) {
  PoseGraph g = Parse(k2D);
  InitializeChordal(g);
  EXPECT_EQ(g.vertex(7).x[0], 1.0);  // FIX 7
  Edge e;
  e.kind = EdgeKind::kLandmark;
  e.from = 7;
  e.to = 0;
  EXPECT_THROW(g.AddEdge(e), std::invalid_argument);
  EXPECT_THROW(RequireNoLandmarks(g, "this"), std::invalid_argument);
  EXPECT_NO_THROW(RequireNoLandmarks(PoseGraph(2), "this"));
}

}  // namespace
}  // namespace cairn
