#include "cairn/graph/simulate.h"

#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <type_traits>

namespace cairn {
namespace {

// The noisy graph's estimate: odometry measurements chained from pose 0.
template <typename Pose>
void ChainOdometry(Simulation& sim) {
  for (const Edge& e : sim.noisy.edges()) {
    if (e.kind != EdgeKind::kOdometry) continue;
    sim.noisy.vertex(e.to).x =
        ToParams(ToPose<Pose>(sim.noisy.vertex(e.from).x) * ToPose<Pose>(e.z));
  }
}

class Noise {
 public:
  Noise(const SimulationOptions& o) : rng_(o.seed), o_(o) {}

  double Gauss(double sigma) { return sigma > 0 ? sigma * normal_(rng_) : 0.0; }
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  bool Chance(double p) { return Uniform(0, 1) < p; }
  size_t Index(size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng_); }

  SE2 Perturb(const SE2& z) {
    return z.BoxPlus(Eigen::Vector3d(Gauss(o_.translation_noise), Gauss(o_.translation_noise),
                                     Gauss(o_.rotation_noise)));
  }
  SE3 Perturb(const SE3& z) {
    Vector6d d;
    for (int i = 0; i < 3; ++i) d[i] = Gauss(o_.translation_noise);
    for (int i = 3; i < 6; ++i) d[i] = Gauss(o_.rotation_noise);
    return z.BoxPlus(d);
  }

 private:
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  const SimulationOptions& o_;
};

// Information matching the simulated noise; g2o's SE3 rotation error is the
// quaternion's vector part (half the angle), hence the factor 4 there.
Matrix6d Information(const SimulationOptions& o) {
  const double st = std::max(o.translation_noise, 1e-4), sr = std::max(o.rotation_noise, 1e-5);
  Matrix6d info = Matrix6d::Zero();
  if (o.dimension == 2) {
    info.diagonal().head<3>() << 1 / (st * st), 1 / (st * st), 1 / (sr * sr);
  } else {
    info.diagonal() << Eigen::Vector3d::Constant(1 / (st * st)),
        Eigen::Vector3d::Constant(4 / (sr * sr));
  }
  return info;
}

template <typename Pose>
void AddMeasurement(Simulation& sim, Noise& noise, const Matrix6d& info, int64_t a, int64_t b,
                    EdgeKind kind) {
  const Pose rel = ToPose<Pose>(sim.truth.vertex(a).x).Between(ToPose<Pose>(sim.truth.vertex(b).x));
  Edge e;
  e.kind = kind;
  e.from = a;
  e.to = b;
  e.z = ToParams(noise.Perturb(rel));
  e.information = info;
  sim.noisy.AddEdge(e);
  sim.truth.AddEdge(e);
}

// Poses along a random walk on a 1 m grid; turns are multiples of 90 degrees.
std::vector<SE2> ManhattanWalk(int n, Noise& noise) {
  const int half = std::max(2, static_cast<int>(std::sqrt(static_cast<double>(n)) / 2));
  std::vector<SE2> poses;
  int x = 0, y = 0, heading = 0;
  const int dx[4] = {1, 0, -1, 0}, dy[4] = {0, 1, 0, -1};
  poses.emplace_back(0, 0, 0);
  while (static_cast<int>(poses.size()) < n) {
    if (noise.Chance(0.3)) heading = (heading + (noise.Chance(0.5) ? 1 : 3)) % 4;
    // Turn back towards the middle at the edge of the world.
    while (std::abs(x + dx[heading]) > half || std::abs(y + dy[heading]) > half)
      heading = (heading + 1) % 4;
    x += dx[heading];
    y += dy[heading];
    poses.emplace_back(x, y, heading * M_PI / 2);
  }
  return poses;
}

// Circles of a sphere, one per lap, climbing from pole to pole; each pose
// faces along its circle.
std::vector<SE3> SphereLaps(const SimulationOptions& o) {
  std::vector<SE3> poses;
  const int laps = (o.poses + o.nodes_per_lap - 1) / o.nodes_per_lap;
  for (int i = 0; i < o.poses; ++i) {
    const int lap = i / o.nodes_per_lap, k = i % o.nodes_per_lap;
    const double polar = M_PI * (lap + 1.0) / (laps + 1.0);
    const double azimuth = 2 * M_PI * k / o.nodes_per_lap;
    const Eigen::Vector3d t(o.radius * std::sin(polar) * std::cos(azimuth),
                            o.radius * std::sin(polar) * std::sin(azimuth),
                            -o.radius * std::cos(polar));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(azimuth + M_PI / 2, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(M_PI / 2 - polar, Eigen::Vector3d::UnitY()));
    poses.emplace_back(q, t);
  }
  return poses;
}

// A point within `radius` of `centre`, uniformly in the disc (2D) or ball.
Eigen::Vector3d NearPoint(Noise& noise, const Eigen::Vector3d& centre, double radius, int dim) {
  for (;;) {
    Eigen::Vector3d d(noise.Uniform(-1, 1), noise.Uniform(-1, 1), dim == 3 ? noise.Uniform(-1, 1) : 0);
    if (d.squaredNorm() <= 1) return centre + radius * d;
  }
}

Eigen::Vector3d PoseTranslation(const PoseGraph& g, const Vertex& v) {
  return g.dimension() == 2 ? Eigen::Vector3d(v.x[0], v.x[1], 0) : Eigen::Vector3d(v.x[0], v.x[1], v.x[2]);
}

// Landmarks after every pose edge, so that the poses' part of a simulation
// does not depend on them: the truth's points, each pose's observations
// within range, and the noisy graph's points placed from their first.
void AddLandmarks(Simulation& sim, Noise& noise, const SimulationOptions& o) {
  const int dim = o.dimension;
  const double range = o.landmark_range > 0 ? o.landmark_range : (dim == 2 ? 3.0 : 10.0);
  const int64_t first = o.poses;
  if (dim == 3) {
    sim.truth.SetOffset(0, SE3());
    sim.noisy.SetOffset(0, SE3());
  }
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < o.landmarks; ++k) {
    const Vertex& near = sim.truth.vertices()[noise.Index(static_cast<size_t>(o.poses))];
    points.push_back(NearPoint(noise, PoseTranslation(sim.truth, near), range / 2, dim));
    sim.truth.AddLandmark(first + k, points.back());
    sim.noisy.AddLandmark(first + k, Eigen::Vector3d::Zero());
  }
  const double st = std::max(o.translation_noise, 1e-4);
  Matrix6d info = Matrix6d::Zero();
  info.diagonal().head(dim).setConstant(1 / (st * st));
  for (int64_t i = 0; i < o.poses; ++i) {
    const Vertex& pose = sim.truth.vertex(i);
    for (int k = 0; k < o.landmarks; ++k) {
      if ((points[k] - PoseTranslation(sim.truth, pose)).norm() > range) continue;
      Edge e;
      e.kind = EdgeKind::kLandmark;
      e.from = i;
      e.to = first + k;
      e.information = info;
      Eigen::Vector3d z;
      if (dim == 2) {
        const Eigen::Vector2d local = ToSE2(pose.x).Inverse() * points[k].head<2>();
        z << local, 0;
      } else {
        z = ToSE3(pose.x).Inverse() * points[k];
      }
      for (int a = 0; a < dim; ++a) e.z[a] = z[a] + noise.Gauss(o.translation_noise);
      sim.noisy.AddEdge(e);
      sim.truth.AddEdge(e);
    }
  }
  PlaceLandmarks(sim.noisy);
}

}  // namespace


Simulation Simulate(const SimulationOptions& o) {
  if (o.dimension != 2 && o.dimension != 3) throw std::invalid_argument("dimension must be 2 or 3");
  if (o.poses < 2) throw std::invalid_argument("a simulation needs at least 2 poses");
  if (o.poses > 10000000) throw std::invalid_argument("at most 10,000,000 poses");
  if (o.translation_noise < 0 || o.rotation_noise < 0)
    throw std::invalid_argument("noise must be non-negative");
  if (o.loop_probability < 0 || o.loop_probability > 1)
    throw std::invalid_argument("the loop-closure probability must be in [0, 1]");
  if (o.outliers < 0) throw std::invalid_argument("the number of outliers must be non-negative");
  if (o.dimension == 3 && (o.nodes_per_lap < 3 || o.radius <= 0))
    throw std::invalid_argument("a sphere needs at least 3 nodes per lap and a positive radius");
  if (o.landmarks < 0 || o.landmark_range < 0)
    throw std::invalid_argument("the landmarks and their range must be non-negative");
  // Every pose is tested against every landmark.
  if (static_cast<double>(o.landmarks) * o.poses > 1e8)
    throw std::invalid_argument("at most 1e8 pose-landmark pairs (poses times landmarks)");

  Simulation sim{PoseGraph(o.dimension), PoseGraph(o.dimension), {}};
  Noise noise(o);
  const Matrix6d info = Information(o);

  if (o.dimension == 2) {
    const std::vector<SE2> truth = ManhattanWalk(o.poses, noise);
    std::map<std::pair<long, long>, std::vector<int64_t>> visits;
    for (int64_t i = 0; i < o.poses; ++i) {
      sim.truth.AddVertex(i, truth[i]);
      sim.noisy.AddVertex(i, truth[i]);
      if (i > 0) AddMeasurement<SE2>(sim, noise, info, i - 1, i, EdgeKind::kOdometry);
      auto& seen = visits[{std::lround(truth[i].x()), std::lround(truth[i].y())}];
      for (int64_t j : seen)
        if (j < i - 1 && noise.Chance(o.loop_probability))
          AddMeasurement<SE2>(sim, noise, info, j, i, EdgeKind::kLoopClosure);
      seen.push_back(i);
    }
    ChainOdometry<SE2>(sim);
  } else {
    const std::vector<SE3> truth = SphereLaps(o);
    for (int64_t i = 0; i < o.poses; ++i) {
      sim.truth.AddVertex(i, truth[i]);
      sim.noisy.AddVertex(i, truth[i]);
      if (i > 0) AddMeasurement<SE3>(sim, noise, info, i - 1, i, EdgeKind::kOdometry);
      // The same place on the previous lap, and its neighbours.
      const int64_t below = i - o.nodes_per_lap;
      for (int64_t j : {below - 1, below, below + 1})
        if (j >= 0 && j < i - 1 && noise.Chance(o.loop_probability))
          AddMeasurement<SE3>(sim, noise, info, j, i, EdgeKind::kLoopClosure);
    }
    ChainOdometry<SE3>(sim);
  }

  // Wrong loop closures: random pairs, random measurements, the information
  // of a good one, so that only their inconsistency gives them away.
  for (int k = 0; k < o.outliers; ++k) {
    int64_t a = static_cast<int64_t>(noise.Index(o.poses));
    int64_t b = static_cast<int64_t>(noise.Index(o.poses));
    if (std::llabs(a - b) < 2) {
      --k;
      continue;
    }
    Edge e;
    e.kind = EdgeKind::kLoopClosure;
    e.from = std::min(a, b);
    e.to = std::max(a, b);
    e.information = info;
    if (o.dimension == 2) {
      e.z = ToParams(SE2(noise.Uniform(-5, 5), noise.Uniform(-5, 5), noise.Uniform(-M_PI, M_PI)));
    } else {
      Vector6d d;
      for (int i = 0; i < 3; ++i) d[i] = noise.Uniform(-5, 5);
      for (int i = 3; i < 6; ++i) d[i] = noise.Uniform(-1.5, 1.5);
      e.z = ToParams(SE3().BoxPlus(d));
    }
    sim.noisy.AddEdge(e);
    sim.truth.AddEdge(e);
    sim.outliers.emplace_back(e.from, e.to);
  }
  if (o.landmarks > 0) AddLandmarks(sim, noise, o);
  return sim;
}

}  // namespace cairn
