#include "cairn/robust/corrupt.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

namespace cairn {

std::vector<VertexPair> AddWrongLoopClosures(PoseGraph& graph, int count, uint64_t seed) {
  if (count < 0) throw std::invalid_argument("the number of outliers must be non-negative");
  if (count == 0) return {};
  RequireNoLandmarks(graph, "adding wrong loop closures");  // it picks vertices as poses
  const auto& vertices = graph.vertices();
  if (vertices.size() < 3)
    throw std::invalid_argument("a graph of fewer than 3 vertices has no room for loop closures");
  std::set<VertexPair> joined;
  std::vector<const Edge*> closures, odometry;
  double reach = 0;  // the largest translation a loop closure measures
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    joined.insert(std::minmax(e.from, e.to));
    if (e.kind == EdgeKind::kLoopClosure) {
      closures.push_back(&e);
      const double t = graph.dimension() == 2
                           ? std::hypot(e.z[0], e.z[1])
                           : std::sqrt(e.z[0] * e.z[0] + e.z[1] * e.z[1] + e.z[2] * e.z[2]);
      reach = std::max(reach, t);
    } else {
      odometry.push_back(&e);
    }
  }
  if (reach <= 0) reach = 5.0;  // no loop closure to learn from: a room's size
  std::vector<const Edge*>& pool = closures.empty() ? odometry : closures;
  Matrix6d info = Matrix6d::Identity();
  if (!pool.empty()) {
    // The median by trace: a typical loop closure, not the most certain.
    std::sort(pool.begin(), pool.end(), [](const Edge* a, const Edge* b) {
      return a->information.trace() < b->information.trace();
    });
    info = pool[pool.size() / 2]->information;
  }

  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, vertices.size() - 1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<VertexPair> added;
  const size_t max_tries = 1000 * static_cast<size_t>(count) + 1000;
  for (size_t tries = 0; added.size() < static_cast<size_t>(count); ++tries) {
    if (tries > max_tries)
      throw std::invalid_argument("could not find " + std::to_string(count) +
                                  " unjoined pairs of vertices");
    int64_t a = vertices[pick(rng)].id, b = vertices[pick(rng)].id;
    if (a > b) std::swap(a, b);
    // Consecutive ids read back as odometry; joined pairs would be duplicates.
    if (b - a < 2 || joined.count({a, b})) continue;
    Edge e;
    e.kind = EdgeKind::kLoopClosure;
    e.from = a;
    e.to = b;
    e.information = info;
    if (graph.dimension() == 2) {
      e.z = {reach * unit(rng), reach * unit(rng), M_PI * unit(rng)};
    } else {
      // A uniform rotation: a normalised 4D Gaussian.
      Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
      q.normalize();
      e.z = {reach * unit(rng), reach * unit(rng), reach * unit(rng), q.x(), q.y(), q.z(), q.w()};
    }
    graph.AddEdge(e);
    joined.insert({a, b});
    added.emplace_back(a, b);
  }
  return added;
}

}  // namespace cairn
