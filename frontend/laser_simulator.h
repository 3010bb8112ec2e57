// Synthetic CARMEN laser logs with ground truth: a random building
// (corridors that close loops, rooms off them, furniture), a robot driving
// through it, a laser scanning it and wheel odometry with noise and a
// systematic error. The scan lines' poses are the true ones, so `cairn
// map`'s ATE against them measures the front-end, not another SLAM run, on
// as many buildings as there are seeds.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <vector>

#include "cairn/graph/geometry.h"

namespace cairn::frontend {

struct LaserSimulationOptions {
  uint64_t seed = 1;
  double path_length = 300;  // metres driven
  // A scan every this many metres or radians of turn, whichever comes first.
  double scan_spacing = 0.8, scan_turn = 0.35;
  int beams = 181;
  double fov = 3.14159265358979323846;  // radians, centred ahead
  double max_range = 50;                // metres; no return reads this
  double range_noise = 0.01;            // metres, standard deviation
  // Odometry: random error per step (a share of the distance and of the
  // turn, and heading per metre), and a systematic one drawn once per log
  // (scale of the distance and of the turn within +-, heading bias per
  // metre within +-).
  double translation_noise = 0.04, rotation_noise = 0.04, heading_noise_per_m = 0.01;
  double scale_error = 0.03, turn_scale_error = 0.03, heading_bias_per_m = 0.01;
};

struct LaserSimulation {
  std::vector<SE2> truth;                  // the robot at each scan
  std::vector<SE2> odometry;               // measured motion from scan k-1 to k (k = 0: identity)
  std::vector<std::vector<float>> ranges;  // each scan's readings, first beam at -fov/2
  double width = 0, height = 0;            // the building, metres
  LaserSimulationOptions options;
};

// Deterministic in options.seed.
LaserSimulation SimulateLaserLog(const LaserSimulationOptions& options);

// As a corrected CARMEN log: PARAM lines for the laser's geometry, an ODOM
// line before each scan (the chain restarting at the previous scan's pose,
// as in the public corrected logs), FLASER lines carrying the true pose.
void WriteCarmenLog(const LaserSimulation& sim, std::ostream& os);

}  // namespace cairn::frontend
