#include "backend/initialization.h"

#include <algorithm>
#include <numeric>
#include <queue>
#include <unordered_map>

namespace cairn {
namespace {

// Adjacency by vertex index: (edge index, neighbour index) pairs.
std::vector<std::vector<std::pair<size_t, size_t>>> Adjacency(const PoseGraph& graph) {
  std::vector<std::vector<std::pair<size_t, size_t>>> adj(graph.vertices().size());
  const auto& edges = graph.edges();
  for (size_t k = 0; k < edges.size(); ++k) {
    if (edges[k].IsPrior()) continue;
    const size_t a = graph.VertexIndex(edges[k].from), b = graph.VertexIndex(edges[k].to);
    adj[a].emplace_back(k, b);
    adj[b].emplace_back(k, a);
  }
  return adj;
}

// Pose of `to_index` from the pose of the other end of edge `e`.
PoseParams Propagate(const PoseGraph& graph, const Edge& e, const PoseParams& from_pose,
                     bool forward) {
  if (graph.dimension() == 2) {
    const SE2 z = ToSE2(e.z);
    return ToParams(ToSE2(from_pose) * (forward ? z : z.Inverse()));
  }
  const SE3 z = ToSE3(e.z);
  return ToParams(ToSE3(from_pose) * (forward ? z : z.Inverse()));
}

}  // namespace

void InitializeBySpanningTree(PoseGraph& graph) {
  auto& vertices = graph.vertices();
  const size_t n = vertices.size();
  const auto adj = Adjacency(graph);
  const int dim = graph.TangentSize();
  std::vector<double> certainty(graph.edges().size());
  for (size_t k = 0; k < graph.edges().size(); ++k)
    certainty[k] = graph.edges()[k].information.topLeftCorner(dim, dim).trace();

  // Roots first: fixed vertices, then the rest by id.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (vertices[a].fixed != vertices[b].fixed) return vertices[a].fixed;
    return vertices[a].id < vertices[b].id;
  });

  std::vector<bool> done(n, false);
  // Prim's algorithm on a max-heap of (certainty, edge, vertex reached).
  using Item = std::tuple<double, size_t, size_t>;
  for (size_t root : order) {
    if (done[root]) continue;
    done[root] = true;
    std::priority_queue<Item> heap;
    auto push_from = [&](size_t v) {
      for (const auto& [k, w] : adj[v])
        if (!done[w]) heap.emplace(certainty[k], k, w);
    };
    push_from(root);
    while (!heap.empty()) {
      const auto [c, k, w] = heap.top();
      heap.pop();
      if (done[w]) continue;
      const Edge& e = graph.edges()[k];
      const bool forward = graph.VertexIndex(e.to) == w;
      const size_t from = forward ? graph.VertexIndex(e.from) : graph.VertexIndex(e.to);
      if (!vertices[w].fixed) vertices[w].x = Propagate(graph, e, vertices[from].x, forward);
      done[w] = true;
      push_from(w);
    }
  }
}

std::vector<std::vector<int64_t>> ConnectedComponents(const PoseGraph& graph) {
  const size_t n = graph.vertices().size();
  std::vector<size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    const size_t a = find(graph.VertexIndex(e.from)), b = find(graph.VertexIndex(e.to));
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::unordered_map<size_t, size_t> slot;
  std::vector<std::vector<int64_t>> components;
  for (size_t i = 0; i < n; ++i) {
    const size_t r = find(i);
    auto it = slot.find(r);
    if (it == slot.end()) {
      it = slot.emplace(r, components.size()).first;
      components.emplace_back();
    }
    components[it->second].push_back(graph.vertices()[i].id);
  }
  for (auto& c : components) std::sort(c.begin(), c.end());
  std::sort(components.begin(), components.end(),
            [](const auto& a, const auto& b) { return a.front() < b.front(); });
  return components;
}

}  // namespace cairn
