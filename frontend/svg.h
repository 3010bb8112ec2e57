// A small SVG plot of planar trajectories (polylines in metres, y up), for
// looking at dead reckoning beside the optimised path.
#pragma once

#include <string>
#include <vector>

#include "cairn/graph/geometry.h"

namespace cairn::frontend {

struct PlotPath {
  std::string label, colour;
  std::vector<SE2> poses;
};

std::string TrajectorySvg(const std::vector<PlotPath>& paths);

}  // namespace cairn::frontend
