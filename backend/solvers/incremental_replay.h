// Replaying a pose graph as a robot would have built it: poses in id order,
// each with the edges that reach back to poses already there, and an
// incremental update after each pose (or every few). What the per-step cost
// of incremental optimisation is measured with (`cairn replay`, the
// benchmarks, the tests).
#pragma once

#include <cstddef>
#include <functional>
#include <array>
#include <vector>

#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/incremental.h"

namespace cairn {

// How an incremental optimizer is driven at each step.
enum class ReplayMode {
  kPartial,      // IncrementalOptimizer::Update: Gauss-Newton, partial
  kGaussNewton,  // IncrementalOptimizer::Optimize(kGaussNewton): re-solves it all
  kCeres,        // IncrementalOptimizer::Optimize(kCeres)
};

struct ReplayOptions {
  ReplayMode mode = ReplayMode::kPartial;
  int every = 1;  // poses between updates (the last pose always updates)
  IncrementalOptions incremental;
  // Called after each update with the poses fed so far and in all; e.g. a
  // progress line.
  std::function<void(size_t fed, size_t total)> progress;
};

struct ReplayResult {
  std::vector<double> step_s;  // wall time of each step: feeding its poses and updating
  // The process's CPU time of each step: on a machine shared with other
  // jobs, what the step costs when it has a core to itself.
  std::vector<double> step_cpu_s;
  double total_s = 0;          // all steps
  double replay_chi2 = 0;      // g2o's chi2 after the last step, before the exact solve
  double final_chi2 = 0;       // after a final exact Optimize() with the same solver
  double final_time_s = 0;     // that Optimize()
  size_t poses = 0, edges = 0;
  // Per step: the poses fed so far, and (partial updates) what its Update did.
  std::vector<size_t> step_poses;
  std::vector<UpdateResult> step_updates;

  // What the partial updates did over the whole replay, summed from the
  // steps: steps that ordered and factorised afresh (in all, and by why:
  // indexed by RebuildReason) and their wall time, steps that fell back to
  // a whole solve, poses re-linearised, refused steps taken again.
  struct Counts {
    size_t refactorizations = 0, whole_solves = 0, relinearized = 0, retried = 0;
    std::array<size_t, kRebuildReasons> refactorizations_by{};
    double refactorization_steps_s = 0;
  };
  Counts Count() const;
};

// The pose order of a replay: vertex indices sorted by id. Each edge goes in
// with the later (by that order) of its poses, priors with their pose.
// Throws std::invalid_argument for a graph with landmarks.
ReplayResult Replay(const PoseGraph& graph, const ReplayOptions& options);

// The q-quantile (0..1) of the values, by the nearest rank; 0 for none.
double Percentile(std::vector<double> values, double q);

}  // namespace cairn
