// Trajectory plots as standalone SVG, written by hand (no dependency), for
// the back-end and the front-end alike: panels side by side, each scaled to
// its own extent so that a wildly wrong start does not squash the optimised
// result. A panel draws a graph (its odometry and loop closures, landmarks
// as dots) and/or
// labelled pose sequences overlaid in one frame (dead reckoning beside the
// optimised path). 3D graphs are drawn as their x-y projection.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// A pose sequence drawn as one line, in order, and named in the legend.
struct PlotTrajectory {
  std::string label;  // e.g. "dead reckoning"
  std::string color;
  std::vector<SE2> poses;
};

struct PlotPanel {
  const PoseGraph* graph = nullptr;      // may be null: trajectories alone
  std::string title;                     // e.g. "before: chi2 551.7"
  std::string color = "#1f5fbf";         // odometry (the trajectory)
  bool loop_closures = true;             // draw loop closures as thin lines
  std::string loop_color = "#d62728";
  std::vector<PlotTrajectory> trajectories{};  // over the graph, same scale, with a legend
};

// A panel of trajectories alone, e.g. dead reckoning and the optimised path.
PlotPanel TrajectoryPanel(std::vector<PlotTrajectory> trajectories, std::string title = "");

void WriteSvgPlot(std::ostream& out, const std::vector<PlotPanel>& panels,
                  const std::string& title = "");

}  // namespace cairn
