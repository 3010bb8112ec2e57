// `cairn map LOG -o PREFIX`: the front-end end to end, from a CARMEN laser
// log to a pose graph, an occupancy grid and the trajectory.
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/mapper.h"
#include "cairn/frontend/svg.h"
#include "cairn/frontend/trajectory.h"
#include "tools/args.h"
#include "tools/command.h"

namespace cairn::tools {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string Basename(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

void PrintErrors(const char* what, const frontend::TrajectoryErrors& e) {
  std::cerr << std::fixed << std::setprecision(3) << "  " << what << ": ATE " << e.ate_rmse
            << " m, RPE " << e.rpe_trans_rmse << " m / " << e.rpe_rot_rmse_deg << " deg per 1 m ("
            << e.matched << " poses)\n"
            << std::defaultfloat;
}

int RunMap(int argc, char** argv) {
  std::string log_path, prefix, graph_path, reference_map, solver = "ceres";
  double resolution = 0.05, max_range = 0, kf_dist = 0.5, kf_angle_deg = 25;
  bool quiet = false;
  ArgParser args("map LOG -o PREFIX [options]",
                 "Builds a pose graph from a CARMEN laser log (FLASER/ROBOTLASER1 and ODOM lines,\n"
                 "plain or gzip'd) using only the raw odometry and the ranges: scans are tracked\n"
                 "against recent keyframes (correlative search, then point-to-line ICP), loop\n"
                 "closures are verified by scan matching and added with a robust loss, and the\n"
                 "graph is optimised as it grows. Writes PREFIX.pgm + PREFIX.yaml (ROS map_server),\n"
                 "PREFIX.png, PREFIX_trajectory.svg (dead reckoning and result) and\n"
                 "PREFIX_trajectory.tum (keyframes, the log's scan timestamps). When the log holds\n"
                 "reference poses, prints the trajectory errors of dead reckoning and of the result.\n"
                 "Stage timings go to stderr.");
  args.Positional("LOG", &log_path, "CARMEN log (.log or .log.gz)");
  args.Option("output", &prefix, "PREFIX", "output prefix (required)");
  args.Alias("-o", "output");
  args.Option("graph", &graph_path, "OUT.g2o", "also write the optimised pose graph as g2o");
  args.Option("resolution", &resolution, "M", "grid cell size in metres");
  args.Option("solver", &solver, "NAME", "back-end: ceres (Levenberg-Marquardt) or gn (Gauss-Newton)");
  args.Option("max-range", &max_range, "M", "readings at or above this mean no return (0: the log's largest)");
  args.Option("keyframe-distance", &kf_dist, "M", "metres travelled between keyframes");
  args.Option("keyframe-angle", &kf_angle_deg, "DEG", "degrees turned between keyframes");
  args.Option("reference-map", &reference_map, "FILE.png",
              "also draw the grid from the log's own poses, for comparison (never used by the front-end)");
  args.Flag("quiet", &quiet, "do not report loop closures as they are accepted");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (prefix.empty()) {
    PrintError("missing -o PREFIX");
    return 2;
  }
  if (solver != "ceres" && solver != "gn") {
    PrintError("unknown solver '" + solver + "' (ceres or gn)");
    return 2;
  }
  if (!(resolution > 0) || !(kf_dist > 0) || !(kf_angle_deg > 0) || max_range < 0) {
    PrintError("resolution, keyframe distance and angle must be positive");
    return 2;
  }
  const auto t_all = Clock::now();
  auto t = Clock::now();
  const frontend::CarmenLog log = frontend::ReadCarmenLog(log_path);
  const double t_read = Since(t);
  if (log.scans.size() < 2) throw std::runtime_error(log_path + ": fewer than two laser scans");

  frontend::MapperOptions mo;
  mo.keyframe_distance = kf_dist;
  mo.keyframe_angle = kf_angle_deg * M_PI / 180;
  mo.max_range = max_range;
  mo.optimize.solver = ParseSolverKind(solver);
  t = Clock::now();
  const frontend::MapResult res = frontend::BuildPoseGraph(log, mo, quiet ? nullptr : &std::cerr);
  const double t_graph = Since(t);

  t = Clock::now();
  frontend::GridOptions go;
  go.resolution = resolution;
  const frontend::OccupancyGrid grid = frontend::BuildOccupancyGrid(log, res.scan_poses, res.max_range, go);
  const double t_grid = Since(t);
  if (!reference_map.empty()) {
    std::vector<SE2> ref_poses;
    for (const auto& s : log.scans) ref_poses.push_back(s.reference);
    const frontend::OccupancyGrid ref_grid = frontend::BuildOccupancyGrid(log, ref_poses, res.max_range, go);
    WriteFileAtomically(reference_map, [&](std::ostream& o) { frontend::WritePng(ref_grid.ToGray(), o); });
  }

  t = Clock::now();
  WriteFileAtomically(prefix + ".pgm", [&](std::ostream& o) { frontend::WritePgm(grid.ToTrinary(), o); });
  WriteFileAtomically(prefix + ".yaml", [&](std::ostream& o) { o << grid.Yaml(Basename(prefix) + ".pgm"); });
  WriteFileAtomically(prefix + ".png", [&](std::ostream& o) { frontend::WritePng(grid.ToGray(), o); });
  frontend::Trajectory traj;
  std::vector<SE2> kf_poses;
  for (size_t k = 0; k < res.keyframes.size(); ++k) {
    const size_t s = res.keyframes[k].scan;
    kf_poses.push_back(ToSE2(res.graph.vertex(static_cast<int64_t>(k)).x));
    traj.Add(log.scans[s].timestamp, kf_poses.back(), static_cast<long>(s), log.scans[s].timestamp_text);
  }
  frontend::WriteTum(traj, prefix + "_trajectory.tum");
  WriteFileAtomically(prefix + "_trajectory.svg", [&](std::ostream& o) {
    o << frontend::TrajectorySvg({{"dead reckoning", "#d62728", res.dead_reckoning},
                                  {"optimised keyframes", "#1f77b4", kf_poses}});
  });
  if (!graph_path.empty()) WriteG2o(res.graph, graph_path);
  const double t_write = Since(t);

  const auto& st = res.stats;
  std::cerr << log.scans.size() << " scans, " << res.keyframes.size() << " keyframes, "
            << res.graph.CountEdges(EdgeKind::kOdometry) << " odometry edges, " << st.loop_accepted
            << " loop closures accepted of " << st.loop_candidates << " candidates, "
            << st.optimizations << " optimisations (" << solver << "), " << st.tracking_failures
            << " scans fell back to odometry; odometry scale learned " << st.odometry_scale << "\n";
  std::cerr << std::fixed << std::setprecision(2) << "time: read " << t_read << " s, matching "
            << st.seconds_matching << " s (+ local maps " << st.seconds_local_map << " s), loop closure " << st.seconds_loops << " s, optimisation "
            << st.seconds_optimizing << " s (graph total " << t_graph << " s), mapping " << t_grid
            << " s, writing " << t_write << " s, total " << Since(t_all) << " s\n"
            << std::defaultfloat;

  frontend::Trajectory ref, dr;
  for (size_t i = 0; i < log.scans.size(); ++i) {
    ref.Add(log.scans[i].timestamp, log.scans[i].reference, static_cast<long>(i));
    dr.Add(log.scans[i].timestamp, res.dead_reckoning[i], static_cast<long>(i));
  }
  // A raw log's laser lines carry the odometry itself; only a corrected log's
  // poses move otherwise than the odometry, and only those are a reference.
  bool has_reference = false;
  for (size_t i = 1; i < log.scans.size() && !has_reference; ++i) {
    const SE2 d = log.scans[i - 1].reference.Between(log.scans[i].reference)
                      .Between(log.scans[i].odometry_increment);
    has_reference = d.translation().norm() > 1e-6 || std::abs(d.theta()) > 1e-6;
  }
  if (has_reference) {
    std::cerr << "against the log's reference poses:\n";
    PrintErrors("dead reckoning", frontend::EvaluateTrajectory(dr, ref));
    PrintErrors("result        ", frontend::EvaluateTrajectory(traj, ref));
  }
  return 0;
}

}  // namespace

CAIRN_COMMAND("map", "laser log to pose graph, occupancy grid and trajectory", RunMap);

}  // namespace cairn::tools
