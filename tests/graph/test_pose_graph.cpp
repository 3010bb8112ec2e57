// The pose-graph model: validation, edge kinds, chi-squared, components,
// chaining along a spanning tree.
#include <gtest/gtest.h>

#include <limits>
#include <cstring>
#include <set>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_graph.h"

namespace cairn {
namespace {

Edge Between2D(int64_t a, int64_t b, const SE2& z, double w = 1.0) {
  Edge e;
  e.kind = KindForBetween(a, b);
  e.from = a;
  e.to = b;
  e.z = ToParams(z);
  e.information = Matrix6d::Identity() * w;
  return e;
}

TEST(PoseGraph, RefusesBadInput) {
  PoseGraph g(2);
  g.AddVertex(0, SE2());
  g.AddVertex(1, SE2(1, 0, 0));
  EXPECT_THROW(g.AddVertex(1, SE2()), std::invalid_argument);
  EXPECT_THROW(g.AddVertex(2, SE3()), std::invalid_argument);
  EXPECT_THROW(g.AddEdge(Between2D(0, 7, SE2())), std::invalid_argument);
  EXPECT_THROW(g.AddEdge(Between2D(1, 1, SE2())), std::invalid_argument);
  Edge bad = Between2D(0, 1, SE2());
  bad.information(0, 1) = 2.0;  // not symmetric
  EXPECT_THROW(g.AddEdge(bad), std::invalid_argument);
  bad.information(1, 0) = 2.0;  // symmetric, indefinite
  EXPECT_THROW(g.AddEdge(bad), std::invalid_argument);
  EXPECT_NO_THROW(g.AddEdge(Between2D(0, 1, SE2(1, 0, 0))));
  EXPECT_EQ(g.edges().size(), 1u);
}

// Every id pattern finds each vertex where it was put, and nothing else:
// dense ascending, descending, shuffled, with gaps, negative, and ids at
// int64's ends (which leave the array for the hash map part-way).
TEST(VertexIndex, FindsEveryIdInAnyOrder) {
  const int64_t lowest = std::numeric_limits<int64_t>::min();
  const int64_t highest = std::numeric_limits<int64_t>::max();
  std::vector<std::vector<int64_t>> patterns;
  std::vector<int64_t> ids;
  for (int64_t i = 0; i < 5000; ++i) ids.push_back(i);
  patterns.push_back(ids);
  patterns.emplace_back(ids.rbegin(), ids.rend());
  std::vector<int64_t> shuffled = ids;
  for (size_t i = shuffled.size() - 1; i > 0; --i) std::swap(shuffled[i], shuffled[(i * 7919) % (i + 1)]);
  patterns.push_back(shuffled);
  std::vector<int64_t> gaps, negative, ends;
  for (int64_t i = 0; i < 3000; ++i) gaps.push_back(i * 3 + (i % 2));
  for (int64_t i = 0; i < 3000; ++i) negative.push_back(1000 - i);
  for (int64_t i = 0; i < 2000; ++i) ends.push_back(i);
  ends.push_back(highest);
  ends.push_back(lowest);
  for (int64_t i = 0; i < 100; ++i) ends.push_back(highest - 1 - i), ends.push_back(lowest + 1 + i);
  patterns.push_back(gaps);
  patterns.push_back(negative);
  patterns.push_back(ends);
  patterns.push_back({lowest, lowest + 1, highest});
  for (size_t p = 0; p < patterns.size(); ++p) {
    SCOPED_TRACE(p);
    VertexIndex index;
    std::set<int64_t> held;
    for (size_t k = 0; k < patterns[p].size(); ++k) {
      index.Insert(patterns[p][k], k);
      held.insert(patterns[p][k]);
    }
    for (size_t k = 0; k < patterns[p].size(); ++k) {
      ASSERT_TRUE(index.Contains(patterns[p][k]));
      ASSERT_EQ(index.At(patterns[p][k]), k);
    }
    for (int64_t probe : {int64_t{-1}, int64_t{2}, int64_t{5000}, int64_t{1001}, int64_t{-2000},
                          lowest, lowest + 500, highest, highest - 500, int64_t{9000}}) {
      EXPECT_EQ(index.Contains(probe), held.count(probe) != 0) << probe;
      if (!held.count(probe)) EXPECT_THROW(index.At(probe), std::out_of_range) << probe;
    }
  }
}

// The graph keeps of each edge what its dimension and kind use: every kind
// in 2D and 3D reads back as added (the unused parts zero, whatever the
// caller left in them), SetEdge replaces one, KeepEdges drops others in
// order, and the iterators walk them as a vector's would.
TEST(EdgeList, KeepsWhatEachKindUses) {
  for (int dim : {2, 3}) {
    SCOPED_TRACE(dim);
    PoseGraph g(dim);
    if (dim == 2) {
      g.AddVertex(0, SE2());
      g.AddVertex(1, SE2(1, 0, 0.1));
    } else {
      g.AddVertex(0, SE3());
      g.AddVertex(1, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)));
      g.SetOffset(4, SE3());
    }
    g.AddLandmark(2, Eigen::Vector3d(1, 2, 3));
    std::vector<Edge> added;
    const EdgeKind kinds[] = {EdgeKind::kOdometry, EdgeKind::kLoopClosure, EdgeKind::kPrior,
                              EdgeKind::kLandmark, EdgeKind::kLandmarkPrior};
    for (EdgeKind kind : kinds) {
      Edge e;
      e.kind = kind;
      e.from = kind == EdgeKind::kLandmarkPrior ? 2 : 0;
      e.to = kind == EdgeKind::kLandmark ? 2 : 1;
      e.offset = kind == EdgeKind::kLandmark && dim == 3 ? 4 : 0;
      for (int i = 0; i < 7; ++i) e.z[i] = 0.1 * (i + 1) + static_cast<int>(kind);
      const int n = g.ResidualSize(e);
      Eigen::MatrixXd info = Eigen::MatrixXd::Identity(n, n) * (2 + static_cast<int>(kind));
      info(0, 1) = info(1, 0) = 0.25;
      e.information.SetTopLeft(info);
      g.AddEdge(e);
      Edge expected = e;  // what is stored of it
      const int used = e.IsLandmark() ? dim : g.ParameterSize();
      for (int i = used; i < 7; ++i) expected.z[i] = 0;
      added.push_back(expected);
    }
    ASSERT_EQ(g.edges().size(), added.size());
    for (size_t k = 0; k < added.size(); ++k) {
      const Edge e = g.edges()[k];
      EXPECT_EQ(e.kind, added[k].kind);
      EXPECT_EQ(e.from, added[k].from);
      EXPECT_EQ(e.to, added[k].to);
      EXPECT_EQ(e.offset, added[k].offset);
      EXPECT_EQ(e.z, added[k].z);
      EXPECT_EQ(e.information, added[k].information);
      EXPECT_EQ(g.edges().kind(k), added[k].kind);
    }
    // Numbers in the unused parts are not kept.
    Edge noisy = added[0];
    noisy.z[6] = 9;
    noisy.information(5, 5) = 9;
    if (dim == 2) {
      g.SetEdge(0, noisy);
      EXPECT_EQ(g.edges()[0].z, added[0].z);
      EXPECT_EQ(g.edges()[0].information, added[0].information);
    }
    noisy = added[1];
    noisy.z[0] = -5;
    g.SetEdge(1, noisy);
    EXPECT_EQ(g.edges()[1].z[0], -5);
    std::vector<Edge> walked(g.edges().begin(), g.edges().end());
    ASSERT_EQ(walked.size(), added.size());
    EXPECT_EQ(g.edges().end() - g.edges().begin(), static_cast<std::ptrdiff_t>(added.size()));
    EXPECT_EQ((*(g.edges().begin() + 3)).kind, EdgeKind::kLandmark);
    EXPECT_EQ(g.edges().back().kind, EdgeKind::kLandmarkPrior);
    g.KeepEdges({false, true, false, true, true});
    ASSERT_EQ(g.edges().size(), 3u);
    EXPECT_EQ(g.edges()[0].z[0], -5);
    EXPECT_EQ(g.edges()[1].kind, EdgeKind::kLandmark);
    EXPECT_EQ(g.edges()[1].information, added[3].information);
    EXPECT_EQ(g.edges()[2].kind, EdgeKind::kLandmarkPrior);
    EXPECT_THROW(g.KeepEdges({true}), std::invalid_argument);
    EXPECT_THROW(g.edges().at(3), std::out_of_range);
  }
}

// Information matrices are interned: edges whose triangles are equal to the
// bit share one, and every edge still reads back its own, whether the
// triangles repeat (a front-end's usual), alternate between kinds, all
// differ, or differ only in the sign of a zero; replacing or dropping an
// edge leaves the others as they were.
TEST(EdgeList, SharedInformationReadsBackPerEdge) {
  PoseGraph g(3);
  for (int64_t i = 0; i < 40; ++i)
    g.AddVertex(i, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 0)));
  std::vector<Edge> added;
  for (int64_t i = 0; i + 1 < 40; ++i) {
    Edge e;
    e.kind = i % 3 == 0 ? EdgeKind::kLoopClosure : EdgeKind::kOdometry;
    e.from = i;
    e.to = i + 1;
    e.z = {1, 0, 0, 0, 0, 0, 1};
    Matrix6d info = Matrix6d::Identity() * (e.kind == EdgeKind::kOdometry ? 100.0 : 7.0);
    if (i >= 20) info(2, 2) += 1e-9 * static_cast<double>(i);  // from here on all differ
    if (i == 12 || i == 13) info(0, 1) = info(1, 0) = (i == 12 ? 0.0 : -0.0);
    e.information = info;
    g.AddEdge(e);
    added.push_back(e);
  }
  auto expect_all = [&](const std::vector<Edge>& want) {
    ASSERT_EQ(g.edges().size(), want.size());
    for (size_t k = 0; k < want.size(); ++k) {
      const Edge e = g.edges()[k];
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) {
          const double a = e.information(r, c), b = want[k].information(r, c);
          ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << "edge " << k << " (" << r << "," << c << ")";
        }
    }
  };
  expect_all(added);
  // One edge of a shared triangle changed: the others keep theirs.
  Edge changed = added[4];
  changed.information(3, 3) = 55;
  g.SetEdge(4, changed);
  added[4] = changed;
  expect_all(added);
  // Dropping every other edge keeps what the rest read.
  std::vector<bool> keep(added.size());
  std::vector<Edge> kept;
  for (size_t k = 0; k < added.size(); ++k)
    if ((keep[k] = k % 2 == 0)) kept.push_back(added[k]);
  g.KeepEdges(keep);
  expect_all(kept);
}

TEST(PoseGraph, EdgeKindsFromIds) {
  EXPECT_EQ(KindForBetween(3, 4), EdgeKind::kOdometry);
  EXPECT_EQ(KindForBetween(4, 3), EdgeKind::kOdometry);
  EXPECT_EQ(KindForBetween(3, 9), EdgeKind::kLoopClosure);
}

TEST(PoseGraph, IsSymmetricPositiveDefinite) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  EXPECT_TRUE(IsSymmetricPositiveDefinite(m));
  m(2, 2) = 0;
  EXPECT_FALSE(IsSymmetricPositiveDefinite(m));
  m(2, 2) = std::nan("");
  EXPECT_FALSE(IsSymmetricPositiveDefinite(m));
}

TEST(Chi2, MatchesHandComputedError2D) {
  PoseGraph g(2);
  g.AddVertex(0, SE2(0, 0, 0));
  g.AddVertex(1, SE2(1, 0, 0.1));
  Edge e = Between2D(0, 1, SE2(1, 0, 0));
  // Non-diagonal information: e^T Omega e with e = (0, 0, 0.1).
  Eigen::Matrix3d info;
  info << 2, 0.5, 0.1, 0.5, 3, 0.2, 0.1, 0.2, 4;
  e.information.SetTopLeft(info);
  g.AddEdge(e);
  EXPECT_NEAR(Chi2(g), 4 * 0.01, 1e-15);
  // Moving pose 1 sideways by 0.2 in pose 0's frame adds y error.
  g.vertex(1).x = ToParams(SE2(1, 0.2, 0.1));
  const Eigen::Vector3d err(0, 0.2, 0.1);
  EXPECT_NEAR(Chi2(g), err.dot(e.information.topLeftCorner<3, 3>() * err), 1e-14);
}

TEST(Chi2, MatchesHandComputedError3D) {
  PoseGraph g(3);
  g.AddVertex(0, SE3());
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  g.AddVertex(1, SE3(q, Eigen::Vector3d(1, 0, 0)));
  Edge e;
  e.kind = EdgeKind::kOdometry;
  e.from = 0;
  e.to = 1;
  e.z = ToParams(SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)));
  g.AddEdge(e);
  // Rotation error is the quaternion's vector part: sin(0.1) about z.
  EXPECT_NEAR(Chi2(g), std::pow(std::sin(0.1), 2), 1e-15);
}

TEST(Components, CountsSeparateChains) {
  PoseGraph g(2);
  for (int i = 0; i < 6; ++i) g.AddVertex(i, SE2());
  g.AddEdge(Between2D(0, 1, SE2(1, 0, 0)));
  g.AddEdge(Between2D(1, 2, SE2(1, 0, 0)));
  g.AddEdge(Between2D(3, 4, SE2(1, 0, 0)));
  const auto c = ConnectedComponents(g);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0], (std::vector<int64_t>{0, 1, 2}));
  EXPECT_EQ(c[1], (std::vector<int64_t>{3, 4}));
  EXPECT_EQ(c[2], (std::vector<int64_t>{5}));
}

TEST(SpanningTree, ChainsMeasurementsAlongMostCertainEdges) {
  PoseGraph g(2);
  for (int i = 0; i < 4; ++i) g.AddVertex(i, SE2());
  g.AddEdge(Between2D(0, 1, SE2(1, 0, M_PI / 2), 100));
  g.AddEdge(Between2D(1, 2, SE2(1, 0, M_PI / 2), 100));
  // A weak, inconsistent edge 0-2 must not be followed.
  g.AddEdge(Between2D(0, 2, SE2(5, 5, 0), 0.01));
  // An edge stated backwards (3 -> 2) is inverted on the way.
  g.AddEdge(Between2D(3, 2, SE2(0, -1, 0), 100));
  InitializeBySpanningTree(g);
  const SE2 p2 = ToSE2(g.vertex(2).x), p3 = ToSE2(g.vertex(3).x);
  EXPECT_NEAR(p2.x(), 1, 1e-12);
  EXPECT_NEAR(p2.y(), 1, 1e-12);
  EXPECT_NEAR(p2.theta(), -M_PI, 1e-12);  // pi, kept as -pi
  // x3 = x2 * z^-1 with z = (0, -1, 0): one metre to x2's left, i.e. (1, 0).
  EXPECT_NEAR(p3.x(), 1, 1e-12);
  EXPECT_NEAR(p3.y(), 0, 1e-12);
}

TEST(SpanningTree, TheGraphModelChainsWhatTheInitialiserDoes) {
  // The initialiser is the graph model's chaining, bit for bit, in 3D too.
  PoseGraph a(3);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  for (int i = 0; i < 5; ++i) a.AddVertex(i, SE3());
  for (int i = 0; i + 1 < 5; ++i) {
    Edge e;
    e.from = i;
    e.to = i + 1;
    e.z = ToParams(SE3(q, Eigen::Vector3d(1, 0, 0.1 * i)));
    e.information *= 1 + i;
    a.AddEdge(e);
  }
  Edge loop;
  loop.kind = EdgeKind::kLoopClosure;
  loop.from = 4;
  loop.to = 0;
  loop.z = ToParams(SE3(q.conjugate(), Eigen::Vector3d(-2, 1, 0)));
  loop.information *= 1000;  // the most certain edge: followed first, backwards
  a.AddEdge(loop);
  PoseGraph b = a;
  ChainAlongSpanningTree(a);
  InitializeBySpanningTree(b);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(a.vertex(i).x, b.vertex(i).x) << i;
  // Vertex 4 came from 0 through the loop closure, inverted.
  const SE3 expected = SE3() * ToSE3(loop.z).Inverse();
  EXPECT_TRUE(ToSE3(a.vertex(4).x).translation().isApprox(expected.translation(), 1e-15));
  // ChainMeasurement both ways round.
  const PoseParams x4 = ChainMeasurement(a, loop, a.vertex(0).x, /*forward=*/false);
  EXPECT_EQ(x4, a.vertex(4).x);
  const SE3 back = ToSE3(ChainMeasurement(a, loop, x4, /*forward=*/true));
  EXPECT_LT(back.translation().norm(), 1e-15);
}

}  // namespace
}  // namespace cairn
