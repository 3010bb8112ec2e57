// Initial estimates built from the edges alone, for graphs whose vertices
// carry no (or no useful) estimate, and the graph's connected components.
#pragma once

#include <cstdint>
#include <vector>

#include "backend/pose_graph.h"

namespace cairn {

// Sets every vertex's estimate by chaining measurements outward along a
// spanning tree that prefers the most certain edges (largest information
// trace). Each component starts at its fixed vertex if it has one, else at
// its lowest id, which keeps its current pose. Priors are not followed.
void InitializeBySpanningTree(PoseGraph& graph);

// Vertex ids of each connected component (between-edges only), each sorted,
// components ordered by their lowest id.
std::vector<std::vector<int64_t>> ConnectedComponents(const PoseGraph& graph);

}  // namespace cairn
