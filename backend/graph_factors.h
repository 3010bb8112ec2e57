// What both solvers build from a pose graph: one cost function per edge
// (the factors of factors/), and which vertices are held constant.
#pragma once

#include <ceres/cost_function.h>

#include <vector>

#include "backend/pose_graph.h"

namespace cairn {

// A new autodiff cost function for the edge (the caller owns it).
ceres::CostFunction* MakeCostFunction(const PoseGraph& graph, const Edge& edge);

// Per vertex (in vertices() order): held constant during optimisation. FIX
// vertices are held; when none is and no prior anchors the graph, the
// lowest-id vertex is held as the gauge.
std::vector<bool> HeldConstant(const PoseGraph& graph);

}  // namespace cairn
