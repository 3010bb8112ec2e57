// `cairn map LOG -o PREFIX`: the front-end end to end, from a CARMEN laser
// log to a pose graph, an occupancy grid and the trajectory.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <stdexcept>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/frontend/carmen_log.h"
#include "cairn/frontend/mapper.h"
#include "cairn/graph/svg_plot.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"
#include "tools/args.h"
#include "tools/command.h"
#include "tools/outputs.h"

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

struct MapArgs {
  std::string log_path, prefix, graph_path, reference_map, scan_poses, solver = "ceres", frame = "first-scan";
  double resolution = 0.05, max_range = 0, kf_dist = 0.5, kf_angle_deg = 25;
  double no_return_clear = frontend::GridOptions{}.max_clear_range;
  bool quiet = false;
};

void DeclareOptions(ArgParser& args, MapArgs& a) {
  args.Positional("LOG", &a.log_path, "CARMEN log (.log or .log.gz)");
  args.Option("output", &a.prefix, "PREFIX", "output prefix (required)");
  args.Alias("-o", "output");
  args.Option("graph", &a.graph_path, "OUT.g2o", "also write the optimised pose graph (g2o; TORO if *.graph)");
  args.Option("scan-poses", &a.scan_poses, "FILE.csv",
              "also write every scan's pose (scan,timestamp,x,y,theta; the keyframe's optimised "
              "pose and the scan's tracked offset from it), e.g. for cairn eval --relations");
  args.Option("resolution", &a.resolution, "M", "grid cell size in metres");
  args.Option("solver", &a.solver, "NAME", "back-end: ceres (Levenberg-Marquardt) or gn (Gauss-Newton)");
  args.Option("max-range", &a.max_range, "M",
              "readings at or above this mean no return (0: the maximum the log declares, else "
              "its largest reading)");
  args.Option("no-return-clear", &a.no_return_clear, "M",
              "how far a no-return beam clears free space (0: not at all)");
  args.Option("frame", &a.frame, "first-scan|log",
              "lay the map, trajectory, keyframes and graph in the first scan's frame (that scan "
              "at the origin) or in the log's own (the first scan at the pose its line carries)");
  args.Option("keyframe-distance", &a.kf_dist, "M", "metres travelled between keyframes");
  args.Option("keyframe-angle", &a.kf_angle_deg, "DEG", "degrees turned between keyframes");
  args.Option("reference-map", &a.reference_map, "FILE.png",
              "also draw the grid from the log's own poses, for comparison (never used by the front-end)");
  args.Flag("quiet", &a.quiet,
            "no progress lines (where the walk through the log stands, every 5 s, and each loop "
            "closure accepted)");
}

// The front-end's options from the arguments; false (the error printed)
// when one is out of range.
bool MakeMapperOptions(const MapArgs& a, frontend::MapperOptions* mo) {
  if (a.prefix.empty()) {
    PrintError("missing -o PREFIX");
    return false;
  }
  try {
    mo->optimize.solver = ParseSolverKind(a.solver);
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return false;
  }
  if (!(a.resolution > 0) || !(a.kf_dist > 0) || !(a.kf_angle_deg > 0) || a.max_range < 0 ||
      !(a.no_return_clear >= 0)) {
    PrintError("resolution, keyframe distance and angle must be positive, --max-range and "
               "--no-return-clear not negative");
    return false;
  }
  if (a.frame != "first-scan" && a.frame != "log") {
    PrintError("--frame must be first-scan or log, not '" + a.frame + "'");
    return false;
  }
  mo->keyframe_distance = a.kf_dist;
  mo->keyframe_angle = a.kf_angle_deg * M_PI / 180;
  mo->max_range = a.max_range;
  return true;
}

// Every file the command writes, declared and checked before the log is
// read: the grid (PGM, YAML, PNG), the keyframes' trajectory (TUM, SVG), the
// graph and the reference map when asked.
void DeclareFiles(const MapArgs& a, CommandOutputs& outputs) {
  outputs.Input(a.log_path);
  outputs.Output(a.prefix + ".pgm");
  outputs.Output(a.prefix + ".yaml");
  outputs.Output(a.prefix + ".png");
  outputs.Output(a.prefix + "_trajectory.tum");
  outputs.Output(a.prefix + "_trajectory.svg");
  outputs.Output(a.prefix + "_keyframes.csv");
  outputs.GraphOutput(a.graph_path);
  outputs.Output(a.reference_map, ".png");
  outputs.Output(a.scan_poses, ".csv");
  outputs.Check();
}

// Keyframes by the index of their scan among the log's laser lines, which
// pairs them with the log even where timestamps repeat (csail's 6 digits).
void WriteKeyframes(const frontend::CarmenLog& log, const frontend::MapResult& res, std::ostream& o) {
  o << "keyframe,scan,timestamp,x,y,theta\n";
  char buf[96];
  for (size_t k = 0; k < res.keyframes.size(); ++k) {
    const size_t s = res.keyframes[k].scan;
    const SE2 pose = ToSE2(res.graph.vertex(static_cast<int64_t>(k)).x);
    std::snprintf(buf, sizeof buf, ",%.17g,%.17g,%.17g\n", pose.x(), pose.y(), pose.theta());
    o << k << ',' << s << ',' << log.scans[s].timestamp_text << buf;
  }
}

// Every scan at the pose the map draws it, with its index and stamp.
void WriteScanPoses(const frontend::CarmenLog& log, const frontend::MapResult& res, std::ostream& o) {
  o << "scan,timestamp,x,y,theta\n";
  char buf[96];
  for (size_t s = 0; s < res.scan_poses.size(); ++s) {
    const SE2& pose = res.scan_poses[s];
    std::snprintf(buf, sizeof buf, ",%.17g,%.17g,%.17g\n", pose.x(), pose.y(), pose.theta());
    o << s << ',' << log.scans[s].timestamp_text << buf;
  }
}

// Writes the declared outputs but the reference map, each to its temporary
// (OutputSet::Commit puts them in place); returns the trajectory.
frontend::Trajectory WriteOutputs(const MapArgs& a, const frontend::CarmenLog& log,
                                  const frontend::MapResult& res,
                                  const frontend::OccupancyGrid& grid,
                                  CommandOutputs& outputs) {
  const std::string& prefix = a.prefix;
  outputs.Write(prefix + ".pgm", [&](std::ostream& o) { frontend::WritePgm(grid.ToTrinary(), o); });
  outputs.Write(prefix + ".yaml", [&](std::ostream& o) { o << grid.Yaml(Basename(prefix) + ".pgm"); });
  outputs.Write(prefix + ".png", [&](std::ostream& o) { frontend::WritePng(grid.ToGray(), o); });
  frontend::Trajectory traj;
  std::vector<SE2> kf_poses;
  for (size_t k = 0; k < res.keyframes.size(); ++k) {
    const size_t s = res.keyframes[k].scan;
    kf_poses.push_back(ToSE2(res.graph.vertex(static_cast<int64_t>(k)).x));
    traj.Add(log.scans[s].timestamp, kf_poses.back(), static_cast<long>(s), log.scans[s].timestamp_text);
  }
  outputs.Write(prefix + "_trajectory.tum", [&](std::ostream& o) { frontend::WriteTum(traj, o); });
  outputs.Write(prefix + "_keyframes.csv", [&](std::ostream& o) { WriteKeyframes(log, res, o); });
  outputs.Write(prefix + "_trajectory.svg", [&](std::ostream& o) {
    WriteSvgPlot(o, {TrajectoryPanel({{"dead reckoning", "#d62728", res.dead_reckoning},
                                      {"optimised keyframes", "#1f77b4", kf_poses}})});
  });
  if (!a.graph_path.empty())
    outputs.WriteGraph(a.graph_path, res.graph);
  if (!a.scan_poses.empty())
    outputs.Write(a.scan_poses, [&](std::ostream& o) { WriteScanPoses(log, res, o); });
  return traj;
}

// When the log's poses are a reference (a corrected log), the errors of
// dead reckoning and of the result against them.
void ReportAgainstReference(const frontend::CarmenLog& log, const frontend::MapResult& res,
                            const frontend::Trajectory& traj) {
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
}

int RunMap(int argc, char** argv) {
  MapArgs a;
  ArgParser args("map LOG -o PREFIX [options]",
                 "Builds a pose graph from a CARMEN laser log (FLASER/ROBOTLASER1 and ODOM lines,\n"
                 "plain or gzip'd) using only the raw odometry and the ranges: scans are tracked\n"
                 "against recent keyframes (correlative search, then point-to-line ICP), loop\n"
                 "closures are verified by scan matching and added with a robust loss, and the\n"
                 "graph is optimised as it grows. Writes PREFIX.pgm + PREFIX.yaml (ROS map_server),\n"
                 "PREFIX.png, PREFIX_trajectory.svg (dead reckoning and result) and\n"
                 "PREFIX_trajectory.tum (keyframes, the log's scan timestamps), PREFIX_keyframes.csv\n"
                 "(keyframe,scan,timestamp,x,y,theta; scan: the 0-based index of the keyframe's\n"
                 "laser line among the log's laser lines). When the log holds\n"
                 "reference poses, prints the trajectory errors of dead reckoning and of the result.\n"
                 "Stage timings go to stderr.");
  DeclareOptions(args, a);
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  frontend::MapperOptions mo;
  if (!MakeMapperOptions(a, &mo)) return 2;
  CommandOutputs outputs;
  DeclareFiles(a, outputs);
  const auto t_all = Clock::now();
  auto t = Clock::now();
  const frontend::CarmenLog log = frontend::ReadCarmenLog(a.log_path);
  const double t_read = Since(t);
  if (log.scans.size() < 2) throw std::runtime_error(a.log_path + ": fewer than two laser scans");

  t = Clock::now();
  frontend::MapResult res = frontend::BuildPoseGraph(log, mo, a.quiet ? nullptr : &std::cerr);
  if (a.frame == "log") frontend::LayInLogFrame(log, &res);
  const double t_graph = Since(t);

  t = Clock::now();
  frontend::GridOptions go;
  go.resolution = a.resolution;
  go.max_clear_range = a.no_return_clear;
  const frontend::OccupancyGrid grid = frontend::BuildOccupancyGrid(log, res.scan_poses, res.max_range, go);
  const double t_grid = Since(t);
  if (!a.reference_map.empty()) {
    std::vector<SE2> ref_poses;
    for (const auto& s : log.scans) ref_poses.push_back(s.reference);
    const frontend::OccupancyGrid ref_grid = frontend::BuildOccupancyGrid(log, ref_poses, res.max_range, go);
    outputs.Write(a.reference_map, [&](std::ostream& o) { frontend::WritePng(ref_grid.ToGray(), o); });
  }

  t = Clock::now();
  const frontend::Trajectory traj = WriteOutputs(a, log, res, grid, outputs);
  outputs.Commit();
  const double t_write = Since(t);

  const auto& st = res.stats;
  std::cerr << log.scans.size() << " scans, " << res.keyframes.size() << " keyframes, "
            << res.graph.CountEdges(EdgeKind::kOdometry) << " odometry edges, " << st.loop_accepted
            << " loop closures accepted of " << st.loop_candidates << " candidates ("
            << st.loop_contradicted << " refused by the free space they saw), "
            << st.optimizations << " optimisations (" << a.solver << "), " << st.wide_searches
            << " poor matches searched wide of which " << st.recoveries << " recovered and "
            << st.vetoed << " were refuted by the odometry, " << st.tracking_failures
            << " scans fell back to odometry; odometry scale learned " << st.odometry_scale << "\n";
  std::cerr << std::fixed << std::setprecision(2) << "time: read " << t_read << " s, matching "
            << st.seconds_matching << " s (+ local maps " << st.seconds_local_map << " s), loop closure " << st.seconds_loops << " s, optimisation "
            << st.seconds_optimizing << " s (graph total " << t_graph << " s), mapping " << t_grid
            << " s, writing " << t_write << " s, total " << Since(t_all) << " s\n"
            << std::defaultfloat;
  ReportAgainstReference(log, res, traj);
  return 0;
}

}  // namespace

CAIRN_SOLVING_COMMAND("map", "laser log to pose graph, occupancy grid and trajectory", RunMap);

}  // namespace cairn::tools
