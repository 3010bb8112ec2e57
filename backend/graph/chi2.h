// g2o's chi-squared of a graph at its current estimate: the sum over edges of
// e^T Omega e, with the same error functions the factors optimise.
#pragma once

#include "cairn/graph/pose_graph.h"

namespace cairn {

double EdgeChi2(const PoseGraph& graph, const Edge& edge);
double Chi2(const PoseGraph& graph);

}  // namespace cairn
