// Graphs with nothing (or part of nothing) to solve: no edges, one vertex,
// every vertex fixed, no vertices at all, a component of fixed vertices
// beside one to solve. Both solvers, with every linear solver, answer at
// once and correctly; `cairn optimize` and `cairn compare` exit 0.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "test_util.h"

using namespace cairn;

namespace {

Edge Between(int64_t from, int64_t to, const SE2& z) {
  Edge e;
  e.from = from;
  e.to = to;
  e.z = ToParams(z);
  e.information.SetTopLeft(Eigen::Matrix3d::Identity() * 10);
  return e;
}

PoseGraph NoEdges() {
  PoseGraph g(2);
  for (int i = 0; i < 3; ++i) g.AddVertex(i, SE2(i, 0.5 * i, 0.1 * i));
  return g;
}

PoseGraph OneVertex() {
  PoseGraph g(2);
  g.AddVertex(7, SE2(1, 2, 0.3));
  return g;
}

// Every vertex FIX, with edges that disagree with the estimate: chi2 > 0.
PoseGraph AllFixed() {
  PoseGraph g(2);
  for (int i = 0; i < 3; ++i) g.AddVertex(i, SE2(i, 0, 0), /*fixed=*/true);
  g.AddEdge(Between(0, 1, SE2(1.1, 0.1, 0.05)));
  g.AddEdge(Between(1, 2, SE2(0.9, -0.1, 0.0)));
  return g;
}

PoseGraph AllFixed3D() {
  PoseGraph g(3);
  for (int i = 0; i < 3; ++i)
    g.AddVertex(i, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 0)), true);
  Edge e;
  e.from = 0;
  e.to = 1;
  e.z = ToParams(SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.2, 0.1, 0)));
  e.information = Eigen::Matrix<double, 6, 6>::Identity() * 5;
  g.AddEdge(e);
  return g;
}

// Nothing to solve in one component ({0, 1}, both FIX, disagreeing), an
// ordinary one beside it ({2, 3, 4}), and a vertex (5) whose only edges go
// to fixed vertices.
PoseGraph FixedComponentBesideAFreeOne() {
  PoseGraph g(2);
  g.AddVertex(0, SE2(0, 0, 0), true);
  g.AddVertex(1, SE2(1, 0, 0), true);
  g.AddVertex(2, SE2(5, 5, 0));
  g.AddVertex(3, SE2(6.2, 5.1, 0.1));
  g.AddVertex(4, SE2(7.1, 4.8, -0.1));
  g.AddVertex(5, SE2(0.4, 1.2, 0.2));
  g.AddEdge(Between(0, 1, SE2(1.3, 0.2, 0.1)));
  g.AddEdge(Between(2, 3, SE2(1, 0, 0)));
  g.AddEdge(Between(3, 4, SE2(1, 0, 0)));
  g.AddEdge(Between(2, 4, SE2(2.1, 0.1, 0)));
  g.AddEdge(Between(0, 5, SE2(0.5, 1, 0.1)));
  g.AddEdge(Between(1, 5, SE2(-0.5, 1, 0.1)));
  return g;
}

std::vector<PoseParams> Estimate(const PoseGraph& g) {
  std::vector<PoseParams> x;
  for (const Vertex& v : g.vertices()) x.push_back(v.x);
  return x;
}

// The linear solvers to run the Gauss-Newton path with, and threads: the
// two-halves path needs two to be chosen by kAuto.
struct GnSetup {
  CholeskyKind kind;
  int threads;
};
const GnSetup kSetups[] = {
    {CholeskyKind::kAuto, 2},         {CholeskyKind::kAuto, 1},
    {CholeskyKind::kTwoHalves, 2},    {CholeskyKind::kSupernodalOrSimplicial, 1},
    {CholeskyKind::kSupernodal, 1},   {CholeskyKind::kSimplicial, 1},
    {CholeskyKind::kEigenLDLT, 1},
};

// Nothing to solve: zero iterations, the estimate as it was, chi2 right.
void ExpectImmediateAnswer(const PoseGraph& input, const char* what) {
  const double chi2 = Chi2(input);
  for (const GnSetup& s : kSetups) {
    SCOPED_TRACE(std::string(what) + ", gn " + ToString(s.kind) + ", " +
                 std::to_string(s.threads) + " threads");
    PoseGraph g = input;
    GaussNewtonOptions go;
    go.linear_solver = s.kind;
    go.threads = s.threads;
    const SolveResult r = SolveGaussNewton(g, go);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_TRUE(r.usable) << r.message;
    EXPECT_EQ(r.termination, "convergence");
    EXPECT_DOUBLE_EQ(r.initial_chi2, chi2);
    EXPECT_DOUBLE_EQ(r.final_chi2, chi2);
    EXPECT_EQ(Estimate(g), Estimate(input));
  }
  SCOPED_TRACE(std::string(what) + ", ceres");
  PoseGraph g = input;
  CeresOptions co;
  const SolveResult r = SolveWithCeres(g, co);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_TRUE(r.usable) << r.message;
  EXPECT_DOUBLE_EQ(r.initial_chi2, chi2);
  EXPECT_DOUBLE_EQ(r.final_chi2, chi2);
  EXPECT_EQ(Estimate(g), Estimate(input));
}

}  // namespace

TEST(Degenerate, NoVertices) { ExpectImmediateAnswer(PoseGraph(2), "no vertices"); }
TEST(Degenerate, NoEdges) { ExpectImmediateAnswer(NoEdges(), "no edges"); }
TEST(Degenerate, OneVertex) { ExpectImmediateAnswer(OneVertex(), "one vertex"); }
TEST(Degenerate, AllFixed) { ExpectImmediateAnswer(AllFixed(), "all fixed"); }
TEST(Degenerate, AllFixed3D) { ExpectImmediateAnswer(AllFixed3D(), "all fixed, 3D"); }

TEST(Degenerate, RobustLossOnNothingToSolve) {
  PoseGraph input = AllFixed();
  Edge loop = Between(0, 2, SE2(2.5, 0, 0));
  loop.kind = EdgeKind::kLoopClosure;
  input.AddEdge(loop);
  GaussNewtonOptions go;
  go.loop_closure_loss = ParseRobustLoss("huber:1");
  PoseGraph g = input;
  const SolveResult r = SolveGaussNewton(g, go);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_TRUE(r.converged);
  EXPECT_DOUBLE_EQ(r.final_chi2, Chi2(input));  // g2o's, without the loss
}

TEST(Degenerate, FixedComponentBesideAFreeOne) {
  const PoseGraph input = FixedComponentBesideAFreeOne();
  PoseGraph fixed_part(2);
  fixed_part.AddVertex(0, SE2(0, 0, 0), true);
  fixed_part.AddVertex(1, SE2(1, 0, 0), true);
  fixed_part.AddEdge(Between(0, 1, SE2(1.3, 0.2, 0.1)));
  CeresOptions co;
  co.function_tolerance = co.gradient_tolerance = co.parameter_tolerance = 1e-14;
  PoseGraph gc = input;
  const SolveResult rc = SolveWithCeres(gc, co);
  EXPECT_TRUE(rc.converged) << rc.message;
  // What the fixed component contributes is all that cannot be removed.
  EXPECT_GE(rc.final_chi2, Chi2(fixed_part) * (1 - 1e-9));
  for (const GnSetup& s : kSetups) {
    SCOPED_TRACE(std::string("gn ") + ToString(s.kind));
    PoseGraph g = input;
    GaussNewtonOptions go;
    static_cast<SolverOptions&>(go) = co;
    go.linear_solver = s.kind;
    go.threads = s.threads;
    const SolveResult r = SolveGaussNewton(g, go);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_TRUE(r.usable);
    EXPECT_GT(r.iterations, 0);
    EXPECT_NEAR(r.final_chi2, rc.final_chi2, 1e-6 * rc.final_chi2);
    // The fixed vertices stay where they are.
    EXPECT_EQ(g.vertex(0).x, input.vertex(0).x);
    EXPECT_EQ(g.vertex(1).x, input.vertex(1).x);
  }
}

// ---- The command line ------------------------------------------------------

namespace {

class DegenerateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::path(cairn::testing::TempDir()) / (std::string("deg_") + info->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // `cairn optimize` with each solver and `cairn compare` exit 0, and the
  // optimised graph is the input written back.
  void Check(const std::string& name, const std::string& text) {
    SCOPED_TRACE(name);
    const std::string in = (dir_ / (name + ".g2o")).string();
    std::ofstream(in) << text;
    std::ostringstream expected;
    WriteG2o(ReadGraph(in), expected);
    for (const char* solver : {"gn", "ceres"}) {
      SCOPED_TRACE(solver);
      const std::string out = (dir_ / (name + "_" + solver + ".g2o")).string();
      int status = -1;
      const std::string log = cairn::testing::RunCommand(
          std::string(CAIRN_TOOL) + " optimize " + in + " --solver " + solver + " -o " + out +
              " 2>&1",
          &status);
      EXPECT_EQ(status, 0) << log;
      std::ifstream written(out);
      std::ostringstream got;
      got << written.rdbuf();
      EXPECT_EQ(got.str(), expected.str());
    }
    int status = -1;
    const std::string log = cairn::testing::RunCommand(
        std::string(CAIRN_TOOL) + " compare --quiet --threads 2 " + in + " 2>&1", &status);
    EXPECT_EQ(status, 0) << log;
  }
  std::filesystem::path dir_;
};

}  // namespace

TEST_F(DegenerateCli, NoEdges) {
  Check("no_edges", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0.5 0.1\n");
}

TEST_F(DegenerateCli, OneVertex) { Check("one_vertex", "VERTEX_SE2 0 1 2 0.3\n"); }

TEST_F(DegenerateCli, AllFixed) {
  Check("all_fixed",
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nFIX 0\nFIX 1\n"
        "EDGE_SE2 0 1 1.1 0.1 0.05 10 0 0 10 0 10\n");
}
