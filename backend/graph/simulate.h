// A simulator of noisy pose graphs with known ground truth, for tests, demos
// and benchmarks: a 2D Manhattan-world random walk and a 3D sphere, with
// point landmarks observed within a range if asked for.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

struct SimulationOptions {
  int dimension = 2;               // 2: Manhattan grid walk, 3: sphere
  int poses = 1000;
  double translation_noise = 0.05;  // standard deviation per axis, m
  double rotation_noise = 0.01;     // standard deviation per axis, rad
  // Chance that a revisit of a place (2D) or a neighbour on the previous lap
  // (3D) becomes a loop closure.
  double loop_probability = 0.5;
  int outliers = 0;                 // wrong loop closures added at random
  int nodes_per_lap = 50;           // 3D: poses per circle of the sphere
  double radius = 50.0;             // 3D: radius of the sphere, m
  // Point landmarks, each placed within half the range of a random true
  // pose (so at least that pose sees it); every pose observes every landmark
  // within `landmark_range` (0: 3 m in 2D, 10 m in 3D) as a point in its own
  // frame, with translation_noise per axis. Ids follow the poses'.
  int landmarks = 0;
  double landmark_range = 0;
  uint64_t seed = 1;
};

struct Simulation {
  PoseGraph noisy{2};  // measurements with noise; estimate chained from odometry
  PoseGraph truth{2};  // the same edges, vertices at their true poses
  std::vector<std::pair<int64_t, int64_t>> outliers;  // the wrong loop closures
};

// Throws std::invalid_argument on options out of range.
Simulation Simulate(const SimulationOptions& options);

}  // namespace cairn
