// Information matrices that are not positive definite: a singular one (a
// position-only prior) is taken, an indefinite one refused naming its line,
// or with ReadOptions::repair_information replaced by the nearest positive
// semi-definite matrix and counted.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include <string>

#include "cairn/graph/graph_io.h"
#include "graph/parse_helpers.h"

namespace cairn {
namespace {

using testing::ExpectError;
using testing::Parse;

const std::string kTwoPoses = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";

Eigen::MatrixXd RandomSymmetric(std::mt19937& rng, int n) {
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd a(n, n);
  for (int i = 0; i < a.size(); ++i) a(i) = g(rng);
  return a + a.transpose();
}

TEST(Information, ClassifiedByItsEigenvalues) {
  EXPECT_EQ(ClassifyInformation(Eigen::Matrix3d::Identity()), InformationClass::kPositiveDefinite);
  Eigen::Matrix3d position_only = Eigen::Vector3d(4, 9, 0).asDiagonal();
  EXPECT_EQ(ClassifyInformation(position_only), InformationClass::kSingular);
  double smallest = 1;
  Eigen::Matrix3d indefinite = Eigen::Vector3d(4, 2, -1).asDiagonal();
  EXPECT_EQ(ClassifyInformation(indefinite, &smallest), InformationClass::kIndefinite);
  EXPECT_NEAR(smallest, -0.25, 1e-15);
  EXPECT_EQ(ClassifyInformation(Eigen::Matrix3d::Zero()), InformationClass::kUnusable);
  Eigen::Matrix3d skew = Eigen::Matrix3d::Identity();
  skew(0, 1) = 0.5;
  EXPECT_EQ(ClassifyInformation(skew), InformationClass::kUnusable);
}

// The nearest positive semi-definite matrix in the Frobenius norm keeps the
// eigenvectors and the positive eigenvalues, and sets the rest to zero.
TEST(Information, ClippingKeepsThePositivePart) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::MatrixXd a = RandomSymmetric(rng, 6);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> before(a);
    if (before.eigenvalues()[0] >= 0) continue;
    Eigen::MatrixXd repaired = a;
    const double clipped = ClipToSemiDefinite(&repaired);
    const double largest = before.eigenvalues().cwiseAbs().maxCoeff();
    EXPECT_NEAR(clipped, -before.eigenvalues()[0] / largest, 1e-12);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> after(repaired);
    EXPECT_GT(after.eigenvalues()[0], -1e-12 * largest);
    for (int k = 0; k < 6; ++k) {
      // Each eigenvector of the original: its eigenvalue, or zero if negative.
      const Eigen::VectorXd v = before.eigenvectors().col(k);
      const double expected = std::max(0.0, before.eigenvalues()[k]);
      EXPECT_NEAR(v.dot(repaired * v), expected, 1e-10 * largest);
    }
    EXPECT_NE(ClassifyInformation(repaired), InformationClass::kIndefinite);
  }
}

TEST(Information, SingularIsReadIndefiniteIsRefusedNamingTheOption) {
  const PoseGraph g = Parse(kTwoPoses + "EDGE_SE2 0 1 1 0 0 5 0 0 5 0 0\n"
                                        "EDGE_PRIOR_SE2 0 0 0 0 3 1 0 3 0 0\n");
  ASSERT_EQ(g.edges().size(), 2u);
  EXPECT_EQ(g.edges()[1].information(2, 2), 0);
  EXPECT_EQ(g.information_repairs().matrices, 0u);
  const std::string indefinite = kTwoPoses + "EDGE_SE2 0 1 1 0 0 5 0 0 5 0 1\n"
                                             "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n";
  ExpectError(indefinite, 4, "indefinite (smallest eigenvalue -0.333 times the largest)");
  ExpectError(indefinite, 4, "--repair-information");
}

TEST(Information, RepairCountsAndMeasuresWhatItChanged) {
  ReadOptions repair;
  repair.repair_information = true;
  const std::string text = kTwoPoses + "EDGE_SE2 0 1 1 0 0 5 0 0 5 0 1\n"   // line 3: fine
                                       "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n"   // -1/3
                                       "EDGE_SE2 0 1 1 0 0 4 0 0 1 0 -2\n"  // -1/2
                                       "EDGE_PRIOR_SE2 1 1 0 0 2 0 0 2 0 -1\n";  // -1/2 too
  const PoseGraph g = Parse(text, repair);
  ASSERT_EQ(g.edges().size(), 4u);
  EXPECT_EQ(g.information_repairs().matrices, 3u);
  EXPECT_NEAR(g.information_repairs().largest_clipped, 0.5, 1e-12);
  EXPECT_EQ(g.information_repairs().largest_line, 5u);
  // The good edge is untouched, bit for bit; the repaired ones are usable.
  Eigen::Matrix3d good = Eigen::Vector3d(5, 5, 1).asDiagonal();
  EXPECT_EQ(Eigen::MatrixXd(g.Information(g.edges()[0])), Eigen::MatrixXd(good));
  for (const Edge& e : g.edges())
    EXPECT_NE(ClassifyInformation(g.Information(e)), InformationClass::kIndefinite);
  // diag(4, 1, -2): the negative weight on the heading goes, the rest stays.
  const Eigen::MatrixXd third = g.Information(g.edges()[2]);
  EXPECT_NEAR(third(0, 0), 4, 1e-12);
  EXPECT_NEAR(third(2, 2), 0, 1e-12);
}

TEST(Information, NothingPositiveIsRefusedEvenRepaired) {
  ReadOptions repair;
  repair.repair_information = true;
  ExpectError(kTwoPoses + "EDGE_SE2 0 1 1 0 0 -1 0 0 -1 0 -1\n", 3, "no positive eigenvalue",
              repair);
}

TEST(Information, AddEdgeTakesSingularRefusesIndefinite) {
  PoseGraph g(3);
  g.AddVertex(0, SE3());
  Edge prior;
  prior.kind = EdgeKind::kPrior;
  prior.from = 0;
  prior.information.SetTopLeft(Eigen::Matrix3d::Identity());
  EXPECT_NO_THROW(g.AddEdge(prior));
  prior.information(5, 5) = -1;
  EXPECT_THROW(g.AddEdge(prior), std::invalid_argument);
}

}  // namespace
}  // namespace cairn
