#include "cairn/frontend/mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <ostream>

namespace cairn::frontend {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Coarse and fine maps: the coarse one drives the exhaustive search, the
// fine one its refinement and ICP's correspondences.
struct MapPair {
  std::unique_ptr<MatchMap> coarse, fine;
  explicit MapPair(const PointCloud& world, double coarse_res = 0.1)
      : coarse(std::make_unique<MatchMap>(world, coarse_res, 2.5 * coarse_res, coarse_res)),
        fine(std::make_unique<MatchMap>(world, 0.05, 0.3, 0.05)) {}
};

std::vector<Eigen::Vector2d> SearchPoints(const PointCloud& cloud) {
  return Downsample(cloud, 0.1).points;
}

// ICP's information is for the world-frame pose; the between-factor's error
// lives in the frame of the measured pose.
Eigen::Matrix3d ToBodyFrame(const Eigen::Matrix3d& world_info, const SE2& pose) {
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
  T.topLeftCorner<2, 2>() = pose.rotation();
  return T.transpose() * world_info * T;
}

Eigen::Matrix3d OdometryInformation(const SE2& delta) {
  const double d = delta.translation().norm(), a = std::abs(delta.theta());
  const double sxy = 0.05 + 0.1 * d, st = 0.05 + 0.2 * a + 0.05 * d;
  return Eigen::Vector3d(1 / (sxy * sxy), 1 / (sxy * sxy), 1 / (st * st)).asDiagonal();
}

}  // namespace

bool VerifyLoopClosure(const PointCloud& submap, const PointCloud& query, const SE2& guess,
                       double linear_window, const MapperOptions& o, SE2* pose,
                       Eigen::Matrix3d* information, IcpResult* icp_out) {
  if (submap.size() < 20 || query.size() < 20) return false;
  MapPair maps(submap, 0.15);
  CorrelativeOptions co;
  co.linear_window = linear_window;
  co.angular_window = o.loop_angular_window;
  co.angular_step = 0.0175;
  // A faint pull to the guess: where the walls leave a direction free (a
  // corridor), the current estimate beats an arbitrary point on a flat score.
  co.distance_penalty = 0.05;
  co.runner_up_distance = o.loop_runner_up_distance;
  const CorrelativeResult cr = CorrelativeMatch(*maps.coarse, *maps.fine, SearchPoints(query), guess, co);
  IcpOptions io;
  const IcpResult icp = IcpMatch(*maps.fine, Downsample(query, 0.05), cr.pose, io);
  if (icp_out) *icp_out = icp;
  if (!icp.converged || cr.score < o.loop_min_score || cr.runner_up_ratio > o.loop_max_runner_up || icp.inlier_fraction < o.loop_min_inliers ||
      icp.mean_residual > o.loop_max_residual)
    return false;
  // ICP should only polish the correlative answer; a long slide means the
  // search's peak was not where the fit is.
  if ((icp.pose.translation() - cr.pose.translation()).norm() > 0.3) return false;
  *pose = icp.pose;
  *information = ToBodyFrame(icp.information, icp.pose);
  return true;
}

MapResult BuildPoseGraph(const CarmenLog& log, const MapperOptions& o, std::ostream* progress) {
  MapResult res;
  res.max_range = o.max_range > 0 ? o.max_range : log.max_reading;
  const double match_max = std::min(o.max_match_range, res.max_range - 1e-3);
  const size_t n = log.scans.size();
  res.scan_poses.resize(n);
  res.dead_reckoning.resize(n);
  std::vector<size_t> scan_kf(n);
  std::vector<SE2> scan_rel(n);
  PoseGraph& graph = res.graph;
  auto kf_pose = [&](size_t k) { return ToSE2(graph.vertex(static_cast<int64_t>(k)).x); };

  std::unique_ptr<MapPair> local;
  auto rebuild_local = [&]() {
    PointCloud world;
    const size_t K = res.keyframes.size();
    const size_t first = K > static_cast<size_t>(o.local_map_keyframes) ? K - o.local_map_keyframes : 0;
    for (size_t k = first; k < K; ++k) world.Append(res.keyframes[k].cloud, kf_pose(k));
    const auto t0 = Clock::now();
    // Overlapping keyframes repeat points; one per 2.5 cm is plenty.
    local = std::make_unique<MapPair>(Downsample(world, 0.025));
    res.stats.seconds_local_map += Since(t0);
  };

  SE2 current, dr;
  double odo_num = 0, odo_den = 0;  // least-squares odometry scale
  double path = 0;
  bool loop_pending = false;
  double path_at_last_loop = -1e9;
  size_t last_opt_kf = 0;
  auto optimize = [&](int iterations) {
    const auto t0 = Clock::now();
    const SE2 last_before = kf_pose(res.keyframes.size() - 1);
    OptimizeOptions oo = o.optimize;
    oo.max_iterations = iterations;
    OptimizeGraph(graph, oo);
    // Tracking continues from where the last keyframe now is.
    current = kf_pose(res.keyframes.size() - 1) * last_before.Between(current);
    ++res.stats.optimizations;
    loop_pending = false;
    last_opt_kf = res.keyframes.size() - 1;
    res.stats.seconds_optimizing += Since(t0);
  };

  for (size_t i = 0; i < n; ++i) {
    const LaserScan& scan = log.scans[i];
    PointCloud cloud = ScanToCloud(scan, o.min_range, match_max);
    if (i > 0) dr = dr * scan.odometry_increment;
    res.dead_reckoning[i] = dr;
    if (i == 0) {
      graph.AddVertex(0, SE2(), true);
      res.keyframes.push_back({0, 0.0, std::move(cloud)});
      rebuild_local();
      scan_kf[i] = 0;
      continue;
    }
    const auto t0 = Clock::now();
    const SE2 prev = current;
    // Wheel odometry often has a scale error of a percent or two, which a
    // corridor cannot reveal; learn it where the walls do constrain travel.
    const double scale = odo_den > 1.0 ? std::clamp(odo_num / odo_den, 0.8, 1.25) : 1.0;
    const SE2& inc = scan.odometry_increment;
    const SE2 predicted = current * SE2(scale * inc.x(), scale * inc.y(), inc.theta());
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    bool tracked = false;
    if (cloud.size() >= 20) {
      CorrelativeOptions co;
      co.linear_window = o.track_linear_window;
      co.angular_window = o.track_angular_window;
      const CorrelativeResult cr =
          CorrelativeMatch(*local->coarse, *local->fine, SearchPoints(cloud), predicted, co);
      const PointCloud icp_cloud = Downsample(cloud, 0.05);
      IcpResult icp = IcpMatch(*local->fine, icp_cloud, cr.pose, IcpOptions{});
      // ICP only polishes the search's answer. A long slide is a corridor
      // pulling the pose along its free axis on a few stray pairs: keep the
      // search's pose (which leans on the odometry there) and measure its
      // fit without iterating.
      const SE2 slide = cr.pose.Between(icp.pose);
      if (slide.translation().norm() > o.track_max_slide || std::abs(slide.theta()) > 0.05) {
        IcpOptions still;
        still.max_iterations = 0;
        icp = IcpMatch(*local->fine, icp_cloud, cr.pose, still);
        icp.converged = icp.inliers >= 10;
      }
      if (icp.converged && icp.inlier_fraction >= o.track_min_inliers) {
        current = icp.pose;
        info = ToBodyFrame(icp.information, icp.pose);
        tracked = true;
        const double var_forward = info.inverse()(0, 0);
        if (std::abs(inc.x()) > 0.1 && var_forward < 0.03 * 0.03) {
          odo_num += inc.x() * prev.Between(current).x();
          odo_den += inc.x() * inc.x();
        }
      }
    }
    if (!tracked) {
      current = predicted;
      ++res.stats.tracking_failures;
    }
    path += prev.Between(current).translation().norm();
    res.stats.seconds_matching += Since(t0);

    const size_t last = res.keyframes.size() - 1;
    const SE2 since = kf_pose(last).Between(current);
    if (since.translation().norm() < o.keyframe_distance && std::abs(since.theta()) < o.keyframe_angle) {
      scan_kf[i] = last;
      scan_rel[i] = since;
      continue;
    }
    // A new keyframe, tied to the previous one by the tracked motion.
    const size_t K = res.keyframes.size();
    graph.AddVertex(static_cast<int64_t>(K), current);
    Edge e;
    e.kind = EdgeKind::kOdometry;
    e.from = static_cast<int64_t>(last);
    e.to = static_cast<int64_t>(K);
    e.z = ToParams(since);
    // The tracked pose fuses odometry and the scan match: the match pins
    // what the walls constrain, the odometry the rest (along a corridor).
    info = tracked ? Eigen::Matrix3d(info + OdometryInformation(since)) : OdometryInformation(since);
    e.information.topLeftCorner<3, 3>() = info;
    graph.AddEdge(e);
    res.keyframes.push_back({i, path, std::move(cloud)});
    scan_kf[i] = K;

    // Loop closures: earlier keyframes near the current estimate, far
    // enough back along the path that they are not in the local map.
    const auto t1 = Clock::now();
    std::vector<std::pair<double, size_t>> near;
    const SE2 xk = kf_pose(K);
    for (size_t j = 0; j + 1 < K; ++j) {
      if (path - res.keyframes[j].path < o.loop_min_travel) continue;
      const double travel = std::min(path - res.keyframes[j].path, path - path_at_last_loop);
      const double radius = std::min(o.loop_max_radius, o.loop_radius + o.loop_radius_growth * travel);
      const double d = (kf_pose(j).translation() - xk.translation()).norm();
      if (d <= radius) near.emplace_back(d, j);
    }
    std::sort(near.begin(), near.end());
    std::vector<size_t> tried;
    for (const auto& [d, j] : near) {
      if (static_cast<int>(tried.size()) >= o.loop_max_candidates) break;
      bool close_to_tried = false;
      for (size_t t : tried) close_to_tried |= (j > t ? j - t : t - j) <= 2 * static_cast<size_t>(o.loop_submap_neighbours);
      if (close_to_tried) continue;
      tried.push_back(j);
      ++res.stats.loop_candidates;
      PointCloud submap;
      const size_t lo = j > static_cast<size_t>(o.loop_submap_neighbours) ? j - o.loop_submap_neighbours : 0;
      const size_t hi = std::min(K - 1, j + o.loop_submap_neighbours);
      for (size_t m = lo; m <= hi; ++m) {
        if (path - res.keyframes[m].path < o.loop_min_travel) continue;
        submap.Append(res.keyframes[m].cloud, kf_pose(m));
      }
      PointCloud query;
      const size_t qlo = K + 1 > static_cast<size_t>(o.loop_query_keyframes) ? K + 1 - o.loop_query_keyframes : 0;
      for (size_t m = qlo; m <= K; ++m) query.Append(res.keyframes[m].cloud, xk.Between(kf_pose(m)));
      const double travel = std::min(path - res.keyframes[j].path, path - path_at_last_loop);
      const double window = std::min(o.loop_max_radius, o.loop_radius + o.loop_radius_growth * travel);
      SE2 matched;
      Eigen::Matrix3d linfo;
      if (!VerifyLoopClosure(submap, query, xk, window, o, &matched, &linfo)) continue;
      Edge lc;
      lc.kind = EdgeKind::kLoopClosure;
      lc.from = static_cast<int64_t>(j);
      lc.to = static_cast<int64_t>(K);
      lc.z = ToParams(kf_pose(j).Between(matched));
      lc.information.topLeftCorner<3, 3>() = linfo;
      graph.AddEdge(lc);
      ++res.stats.loop_accepted;
      path_at_last_loop = path;
      loop_pending = true;
      if (progress)
        *progress << "loop closure " << j << " -> " << K << " (scan " << i << "), correction "
                  << (matched.translation() - xk.translation()).norm() << " m\n";
    }
    res.stats.seconds_loops += Since(t1);
    if (loop_pending && K - last_opt_kf >= static_cast<size_t>(o.optimize_every)) optimize(20);
    rebuild_local();
  }
  if (res.keyframes.size() > 1) optimize(std::max(o.optimize.max_iterations, 50));
  res.stats.odometry_scale = odo_den > 1.0 ? std::clamp(odo_num / odo_den, 0.8, 1.25) : 1.0;
  for (size_t i = 0; i < n; ++i) res.scan_poses[i] = kf_pose(scan_kf[i]) * scan_rel[i];
  return res;
}

OccupancyGrid BuildOccupancyGrid(const CarmenLog& log, const std::vector<SE2>& poses,
                                 double max_range, const GridOptions& options) {
  // Beam ends first, for the bounds.
  struct Beam {
    Eigen::Vector2d from, to;
    bool hit;
  };
  std::vector<Beam> beams;
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (size_t i = 0; i < log.scans.size() && i < poses.size(); ++i) {
    const LaserScan& s = log.scans[i];
    const SE2 sensor = poses[i] * s.laser_offset;
    for (size_t b = 0; b < s.ranges.size(); ++b) {
      double r = s.ranges[b];
      if (!(r > 0.01)) continue;
      const bool hit = r < max_range - 1e-3;
      if (!hit) r = std::min(r, options.max_clear_range);
      const double a = s.angle_min + s.angle_increment * b;
      const Eigen::Vector2d end = sensor * Eigen::Vector2d(r * std::cos(a), r * std::sin(a));
      beams.push_back({sensor.translation(), end, hit});
      lo = lo.cwiseMin(end).cwiseMin(sensor.translation());
      hi = hi.cwiseMax(end).cwiseMax(sensor.translation());
    }
  }
  if (beams.empty()) lo = hi = Eigen::Vector2d::Zero();
  const Eigen::Vector2d margin(1.0, 1.0);
  OccupancyGrid grid(lo - margin, hi + margin, options);
  for (const Beam& b : beams) grid.AddBeam(b.from, b.to, b.hit);
  return grid;
}

}  // namespace cairn::frontend
