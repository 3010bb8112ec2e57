#include "cairn/robust/corrupt.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "cairn/graph/geometry.h"

namespace cairn {
namespace {

// What both kinds of wrong loop closure learn from the graph: the pairs
// already joined, how far a loop closure reaches, a typical information.
struct ClosureModel {
  std::set<VertexPair> joined;
  double reach = 0;  // the largest translation a loop closure measures
  Matrix6d info = Matrix6d::Identity();
};

ClosureModel ModelOf(const PoseGraph& graph) {
  ClosureModel m;
  std::vector<const Edge*> closures, odometry;
  const std::vector<Edge> edges(graph.edges().begin(), graph.edges().end());  // decoded once
  for (const Edge& e : edges) {
    if (e.IsPrior()) continue;
    m.joined.insert(std::minmax(e.from, e.to));
    if (e.kind == EdgeKind::kLoopClosure) {
      closures.push_back(&e);
      const double t = graph.dimension() == 2
                           ? std::hypot(e.z[0], e.z[1])
                           : std::sqrt(e.z[0] * e.z[0] + e.z[1] * e.z[1] + e.z[2] * e.z[2]);
      m.reach = std::max(m.reach, t);
    } else {
      odometry.push_back(&e);
    }
  }
  if (m.reach <= 0) m.reach = 5.0;  // no loop closure to learn from: a room's size
  std::vector<const Edge*>& pool = closures.empty() ? odometry : closures;
  if (!pool.empty()) {
    // The median by trace: a typical loop closure, not the most certain.
    std::sort(pool.begin(), pool.end(), [](const Edge* a, const Edge* b) {
      return a->information.trace() < b->information.trace();
    });
    m.info = pool[pool.size() / 2]->information;
  }
  return m;
}

// A random measurement: translation uniform within `reach` per axis,
// rotation uniform (3D: a normalised 4D Gaussian).
PoseParams RandomMeasurement(int dimension, double reach, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  if (dimension == 2) return {reach * unit(rng), reach * unit(rng), M_PI * unit(rng)};
  Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
  q.normalize();
  return {reach * unit(rng), reach * unit(rng), reach * unit(rng), q.x(), q.y(), q.z(), q.w()};
}

void Check(const PoseGraph& graph, int count) {
  if (count < 0) throw std::invalid_argument("the number of outliers must be non-negative");
  RequireNoLandmarks(graph, "adding wrong loop closures");  // it picks vertices as poses
  if (graph.vertices().size() < 3)
    throw std::invalid_argument("a graph of fewer than 3 vertices has no room for loop closures");
}

// z = x_a^-1 T x_b for the group's offset T.
template <typename Pose>
PoseParams AliasedMeasurement(const PoseGraph& poses, const Pose& offset, int64_t a, int64_t b) {
  const Pose xa = ToPose<Pose>(poses.vertex(a).x), xb = ToPose<Pose>(poses.vertex(b).x);
  return ToParams(xa.Inverse() * offset * xb);
}

// T such that x_a^-1 T x_b = z0.
template <typename Pose>
Pose AliasOffset(const PoseGraph& poses, const PoseParams& z0, int64_t a, int64_t b) {
  const Pose xa = ToPose<Pose>(poses.vertex(a).x), xb = ToPose<Pose>(poses.vertex(b).x);
  return xa * ToPose<Pose>(z0) * xb.Inverse();
}

}  // namespace

std::vector<VertexPair> AddWrongLoopClosures(PoseGraph& graph, int count, uint64_t seed) {
  Check(graph, count);
  if (count == 0) return {};
  const auto& vertices = graph.vertices();
  ClosureModel model = ModelOf(graph);
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, vertices.size() - 1);
  std::vector<VertexPair> added;
  const size_t max_tries = 1000 * static_cast<size_t>(count) + 1000;
  for (size_t tries = 0; added.size() < static_cast<size_t>(count); ++tries) {
    if (tries > max_tries)
      throw std::invalid_argument("could not find " + std::to_string(count) +
                                  " unjoined pairs of vertices");
    int64_t a = vertices[pick(rng)].id, b = vertices[pick(rng)].id;
    if (a > b) std::swap(a, b);
    // Consecutive ids read back as odometry; joined pairs would be duplicates.
    if (b - a < 2 || model.joined.count({a, b})) continue;
    Edge e;
    e.kind = EdgeKind::kLoopClosure;
    e.from = a;
    e.to = b;
    e.information = model.info;
    e.z = RandomMeasurement(graph.dimension(), model.reach, rng);
    graph.AddEdge(e);
    model.joined.insert({a, b});
    added.emplace_back(a, b);
  }
  return added;
}

std::vector<VertexPair> AddAliasedLoopClosures(PoseGraph& graph, int count, int group_size,
                                               uint64_t seed, const PoseGraph* poses) {
  Check(graph, count);
  if (group_size < 1) throw std::invalid_argument("the group size must be at least 1");
  if (count == 0) return {};
  const PoseGraph& at = poses ? *poses : graph;
  ClosureModel model = ModelOf(graph);
  const auto& vertices = graph.vertices();
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, vertices.size() - 1);
  // A stretch is usable when its ids are all poses of both graphs and none
  // of its pairs is joined yet.
  auto usable = [&](int64_t a, int64_t b, int n) {
    for (int k = 0; k < n; ++k)
      if (!graph.HasVertex(a + k) || !graph.HasVertex(b + k) || !at.HasVertex(a + k) ||
          !at.HasVertex(b + k) || model.joined.count({a + k, b + k}))
        return false;
    return true;
  };
  std::vector<VertexPair> added;
  const size_t max_tries = 1000 * static_cast<size_t>(count) + 1000;
  for (size_t tries = 0; added.size() < static_cast<size_t>(count); ++tries) {
    if (tries > max_tries)
      throw std::invalid_argument("could not find room for " + std::to_string(count) +
                                  " aliased loop closures in groups of " +
                                  std::to_string(group_size));
    const int n = std::min<int>(group_size, count - static_cast<int>(added.size()));
    int64_t a = vertices[pick(rng)].id, b = vertices[pick(rng)].id;
    if (a > b) std::swap(a, b);
    // The two stretches apart, so no pair is consecutive or overlapping.
    if (b - a < n + 1 || !usable(a, b, n)) continue;
    const PoseParams z0 = RandomMeasurement(graph.dimension(), model.reach, rng);
    for (int k = 0; k < n; ++k) {
      Edge e;
      e.kind = EdgeKind::kLoopClosure;
      e.from = a + k;
      e.to = b + k;
      e.information = model.info;
      e.z = graph.dimension() == 2
                ? AliasedMeasurement(at, AliasOffset<SE2>(at, z0, a, b), a + k, b + k)
                : AliasedMeasurement(at, AliasOffset<SE3>(at, z0, a, b), a + k, b + k);
      graph.AddEdge(e);
      model.joined.insert({a + k, b + k});
      added.emplace_back(a + k, b + k);
    }
  }
  return added;
}

}  // namespace cairn
