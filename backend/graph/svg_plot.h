// Trajectory plots as standalone SVG, written by hand (no dependency): one
// panel per graph, side by side, each scaled to its own extent so that a
// wildly wrong start does not squash the optimised result. 3D graphs are
// drawn as their x-y projection.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

struct PlotPanel {
  const PoseGraph* graph = nullptr;
  std::string title;                     // e.g. "before: chi2 551.7"
  std::string color = "#1f5fbf";         // odometry (the trajectory)
  bool loop_closures = true;             // draw loop closures as thin lines
  std::string loop_color = "#d62728";
};

void WriteSvgPlot(std::ostream& out, const std::vector<PlotPanel>& panels,
                  const std::string& title = "");

}  // namespace cairn
