// Wrong loop closures added on purpose, to measure how a solver copes with
// them (`cairn corrupt`): random ones, and aliased groups that agree with
// each other and with the odometry, as a place taken for another produces.
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

// Adds `count` wrong loop closures in groups of `group_size` (the last group
// holds the remainder). A group stands for perceptual aliasing: the stretch
// of poses b, b+1, ... is taken to stand elsewhere, by one rigid offset T, and
// its closure k measures z_k = x_{a+k}^-1 T x_{b+k} on the poses of `poses`
// (the graph itself when null; e.g. a simulation's truth), so the group
// agrees with itself and with the odometry of both stretches. T is chosen so
// that the first closure looks like a real one: z_0 is a random measurement
// as AddWrongLoopClosures draws it. Information as AddWrongLoopClosures.
// Stretches are runs of consecutive ids, no pair joined before. Throws
// std::invalid_argument when the graph cannot take them.
std::vector<VertexPair> AddAliasedLoopClosures(PoseGraph& graph, int count, int group_size,
                                               uint64_t seed, const PoseGraph* poses = nullptr);

}  // namespace cairn
