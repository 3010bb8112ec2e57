// Wrong loop closures added on purpose, to measure how a solver copes with
// them (`cairn corrupt`).
#pragma once

#include <cstdint>
#include <vector>

#include "cairn/graph/pose_graph.h"
#include "cairn/robust/vertex_pair.h"

namespace cairn {

// Adds `count` loop closures between random pairs of distinct, non-consecutive
// vertices not yet joined, each with a random measurement (translation
// uniform within the largest loop-closure translation, rotation uniform) and
// the information of the graph's median loop closure (by trace; the median
// odometry edge's when there is none). Returns the pairs added, in order.
// Throws std::invalid_argument when the graph is too small to take them.
std::vector<VertexPair> AddWrongLoopClosures(PoseGraph& graph, int count, uint64_t seed);

}  // namespace cairn
