// The front-end proper: from a laser log to a pose graph. Scans are tracked
// against a local map of recent keyframes (correlative search, then ICP),
// keyframes become graph nodes, loop closures are searched near the current
// estimate and verified by scan matching, and the graph is optimised as it
// grows. Then the occupancy grid from the optimised poses.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"
#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/occupancy_grid.h"
#include "cairn/frontend/optimize.h"
#include "cairn/frontend/scan_matcher.h"

namespace cairn::frontend {

struct MapperOptions {
  double keyframe_distance = 0.5;   // metres travelled
  double keyframe_angle = 0.436;    // radians turned (25 degrees)
  double min_range = 0.05;
  double max_match_range = 60.0;    // longer beams are too sparse to match well
  // Readings at or above this are "no return"; 0 takes what the log
  // declares (CarmenLog::declared_max_range), else its largest reading.
  double max_range = 0;
  int local_map_keyframes = 10;
  // The tracking search's window, widened up to 3 times as the odometry's
  // recent errors require (2.5 times their 90th percentile).
  double track_linear_window = 0.5;
  double track_angular_window = 0.35;   // 20 degrees
  double track_min_inliers = 0.4;       // below: trust the odometry instead
  double track_max_slide = 0.15;        // metres ICP may move the search's pose
  // A match is judged poor, and searched again wide, when its inlier
  // fraction falls below this share of the recent matches' median, or when
  // the search's best pose lies at the edge of its window (the scan's true
  // pose is likely beyond: an odometry glitch, a slip, a bump).
  double track_relative_inliers = 0.7;
  // The wide search around the prediction: every heading, +- this many metres.
  double recovery_linear_window = 2.0;
  // Its ambiguity test: a pose at the best's heading joined to it by a
  // ridge whose score never falls below this share (a corridor's length)
  // does not count as a second hypothesis (CorrelativeOptions::ridge_share).
  double recovery_ridge_share = 0.85;
  // And the way the robot moved from the last matched pose: a wide pose
  // whose heading does not fit an arc from there scores up to this share
  // lower (CorrelativeOptions::arc_penalty; 0: off).
  double recovery_arc_penalty = 0.4;
  // When the wide search fails too and the scan disputed the odometry (its
  // best pose at the window's edge, or twice the inliers at a wide pose
  // refused as ambiguous), tracking is lost until a match holds again:
  // those steps, and the step out of the loss, keep their motion with the
  // information scaled by this (never a confident wrong edge), keyframes
  // made meanwhile stay out of the local map, and loop closures re-anchor
  // them later. A wide pose refused as ambiguous is taken at the next scan
  // if that scan's wide search lands on it through the odometry.
  double lost_information_scale = 0.01;

  double loop_min_travel = 8.0;         // metres of path between the two ends
  double loop_radius = 1.0;             // candidate radius at zero path...
  double loop_radius_growth = 0.02;     // ...growing per metre of path since...
  double loop_max_radius = 5.0;         // ...up to this
  double loop_angular_window = 0.35;    // 20 degrees
  // Between two keyframes joined through steps the scans did not confirm
  // (the odometry kept, tracking lost), their relative pose is as uncertain
  // as those steps' odometry: the radius grows by three standard deviations
  // of the shift their heading error gives (up to loop_max_radius), the
  // heading window to three of that error, up to this. A loop closure
  // across such steps settles them.
  double loop_max_angular_window = 1.05;  // 60 degrees
  int loop_max_candidates = 2;          // per keyframe
  int loop_submap_neighbours = 3;       // keyframes each side of the candidate
  int loop_query_keyframes = 3;         // the current one and the previous ones
  double loop_min_inliers = 0.6;
  double loop_max_residual = 0.04;
  double loop_min_score = 0.4;
  // Ambiguity test: the best pose at least loop_runner_up_distance from the
  // winner must score below loop_max_runner_up times the winner's score.
  double loop_runner_up_distance = 0.5;
  double loop_max_runner_up = 0.9;

  int optimize_every = 5;  // keyframes between solves triggered by loop closures
  OptimizeOptions optimize;
  // Seconds between the progress lines BuildPoseGraph writes (with a stream).
  double progress_interval_s = 5;
};

struct KeyFrame {
  size_t scan = 0;
  double path = 0;   // metres travelled (tracked) from the start
  PointCloud cloud;  // robot frame
  // Its pose came from the odometry alone while the scans disputed it: kept
  // out of the local map, which it might have turned.
  bool lost = false;
};

struct MapperStats {
  size_t loop_candidates = 0, loop_accepted = 0, optimizations = 0, tracking_failures = 0;
  // Verified by the scans' fit, refused as the scan contradicted the free
  // space seen at that place.
  size_t loop_contradicted = 0;
  // Poor matches searched again wide, and those the wide search recovered.
  size_t wide_searches = 0, recoveries = 0;
  // Poses the searches offered that the odometry's prediction refuted:
  // their scan put walls where the local map saw through, the prediction's
  // did not. The odometry was kept.
  size_t vetoed = 0;
  double odometry_scale = 1;  // the factor learned for the odometry's translation
  double seconds_matching = 0, seconds_local_map = 0, seconds_loops = 0, seconds_optimizing = 0;
};

struct MapResult {
  PoseGraph graph{2};               // vertex k is keyframe k
  std::vector<KeyFrame> keyframes;
  std::vector<SE2> scan_poses;      // every scan, from its keyframe's optimised pose
  std::vector<SE2> dead_reckoning;  // every scan, raw odometry chained from the origin
  double max_range = 0;
  MapperStats stats;
};

// `progress` (may be null) gets a line per loop closure accepted and, every
// progress_interval_s, where the walk through the log stands (scan i of N,
// keyframes, loop closures, scans that fell back to odometry, seconds).
MapResult BuildPoseGraph(const CarmenLog& log, const MapperOptions& options,
                         std::ostream* progress = nullptr);

// BuildPoseGraph lays its result in the first scan's frame (that scan at the
// origin, heading along +x); this moves it into the log's own frame (the
// first scan at the pose its laser line carries), so that it overlays what
// else the log's frame describes. Vertices, scan poses and dead reckoning.
void LayInLogFrame(const CarmenLog& log, MapResult* result);

// The grid from every scan at its pose (beams at max_range only clear).
OccupancyGrid BuildOccupancyGrid(const CarmenLog& log, const std::vector<SE2>& poses,
                                 double max_range, const GridOptions& options);

// Verifies a loop-closure candidate: matches `query` (robot frame) against
// `submap` (world frame) from `guess`, within +- the windows (metres, radians). Returns true and the world pose of
// the query with its information (in the query's frame) if the fitness
// tests pass.
bool VerifyLoopClosure(const PointCloud& submap, const PointCloud& query, const SE2& guess,
                       double linear_window, double angular_window, const MapperOptions& options,
                       SE2* pose, Eigen::Matrix3d* information, IcpResult* icp_out = nullptr);

}  // namespace cairn::frontend
