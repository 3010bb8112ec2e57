#include "cairn/frontend/laser_simulator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>

namespace cairn::frontend {
namespace {

constexpr double kCell = 0.02;   // the building's raster, metres
constexpr double kWall = 0.15;   // wall thickness
constexpr double kDoor = 1.0;    // door width
constexpr double kMargin = 1.0;  // solid ground around the building

// The building as a raster of solid cells, origin at (0, 0).
class Raster {
 public:
  Raster(double width, double height)
      : w_(static_cast<int>(std::ceil(width / kCell))),
        h_(static_cast<int>(std::ceil(height / kCell))),
        solid_(static_cast<size_t>(w_) * h_, 1) {}
  // Every cell whose centre lies in [x0, x1] x [y0, y1].
  void Fill(double x0, double y0, double x1, double y1, bool solid) {
    const int i0 = std::max(0, static_cast<int>(std::ceil(x0 / kCell - 0.5)));
    const int i1 = std::min(w_ - 1, static_cast<int>(std::floor(x1 / kCell - 0.5)));
    const int j0 = std::max(0, static_cast<int>(std::ceil(y0 / kCell - 0.5)));
    const int j1 = std::min(h_ - 1, static_cast<int>(std::floor(y1 / kCell - 0.5)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) solid_[static_cast<size_t>(j) * w_ + i] = solid;
  }
  bool Solid(int i, int j) const {
    return i < 0 || j < 0 || i >= w_ || j >= h_ || solid_[static_cast<size_t>(j) * w_ + i];
  }
  // Distance along the ray to the first solid cell (Amanatides and Woo's
  // traversal), or max_range when there is none that near.
  double Cast(double x, double y, double angle, double max_range) const {
    const double dx = std::cos(angle), dy = std::sin(angle);
    int i = static_cast<int>(std::floor(x / kCell)), j = static_cast<int>(std::floor(y / kCell));
    if (Solid(i, j)) return 0;
    const int si = dx > 0 ? 1 : -1, sj = dy > 0 ? 1 : -1;
    const double inf = std::numeric_limits<double>::infinity();
    const double tdx = dx != 0 ? kCell / std::abs(dx) : inf,
                 tdy = dy != 0 ? kCell / std::abs(dy) : inf;
    double tx = dx != 0 ? ((i + (si > 0)) * kCell - x) / dx : inf;
    double ty = dy != 0 ? ((j + (sj > 0)) * kCell - y) / dy : inf;
    for (;;) {
      double t;
      if (tx < ty) {
        t = tx;
        tx += tdx;
        i += si;
      } else {
        t = ty;
        ty += tdy;
        j += sj;
      }
      if (t > max_range) return max_range;
      if (Solid(i, j)) return t;
    }
  }

 private:
  int w_, h_;
  std::vector<uint8_t> solid_;
};

struct Rng {
  explicit Rng(uint64_t seed) : engine(seed) {}
  double Uniform(double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(engine);
  }
  double Normal(double sigma) {
    return sigma > 0 ? std::normal_distribution<double>(0, sigma)(engine) : 0;
  }
  int Int(int a, int b) { return std::uniform_int_distribution<int>(a, b)(engine); }
  std::mt19937_64 engine;
};

// A room off a corridor: its door, and the point on the corridor's centre
// line in front of it, on the corridor-graph edge `edge`.
struct Room {
  double x0, y0, x1, y1;
  Eigen::Vector2d door, front;
  int edge;
};

// Corridors along x = xs[i] and y = ys[j] (widths xw, yw) cross at the
// graph's nodes (i, j), numbered j * xs.size() + i; edges join neighbours.
struct Building {
  double width = 0, height = 0;
  std::vector<double> xs, ys, xw, yw;
  std::vector<std::pair<int, int>> edges;
  std::vector<Room> rooms;
  int Node(size_t i, size_t j) const { return static_cast<int>(j * xs.size() + i); }
  Eigen::Vector2d At(int node) const { return {xs[node % xs.size()], ys[node / xs.size()]}; }
};

// Centres spread over [lo, hi], each moved a little, and widths.
void Corridors(Rng& rng, int count, double lo, double hi, std::vector<double>* at,
               std::vector<double>* width) {
  for (int k = 0; k < count; ++k) {
    at->push_back(lo + k * (hi - lo) / (count - 1) +
                  (k > 0 && k + 1 < count ? rng.Uniform(-1, 1) : 0));
    width->push_back(rng.Uniform(1.6, 2.6));
  }
}

// Boxes against a room's walls: never against the door's wall, and on the
// side walls only in the half away from it, so the way in stays clear.
void Furnish(Rng& rng, Raster& raster, const Room& r, int door_side) {
  const double w = r.x1 - r.x0, h = r.y1 - r.y0;
  for (int n = rng.Int(0, 4); n-- > 0;) {
    int side = rng.Int(0, 3);
    if (side == door_side) side = (side + 2) % 4;
    const bool across = side == 0 || side == 2;  // against a wall along x
    const double depth = rng.Uniform(0.25, 0.25 * (across ? h : w));
    const double len = rng.Uniform(0.3, std::min(1.5, 0.4 * (across ? w : h)));
    const bool lateral = side != (door_side + 2) % 4;
    double from = rng.Uniform(0, (across ? w : h) - len);
    if (lateral) {  // the half away from the door's wall
      const double half = 0.5 * (across ? w : h);
      const bool door_low = door_side == 0 || door_side == 3;
      from = door_low ? rng.Uniform(half, std::max(half, (across ? w : h) - len))
                      : rng.Uniform(0, std::max(0.0, half - len));
    }
    if (across) {
      const double y = side == 0 ? r.y0 : r.y1 - depth;
      raster.Fill(r.x0 + from, y, r.x0 + from + len, y + depth, true);
    } else {
      const double x = side == 3 ? r.x0 : r.x1 - depth;
      raster.Fill(x, r.y0 + from, x + depth, r.y0 + from + len, true);
    }
  }
}

// The block between corridors i, i+1 (x) and j, j+1 (y), split into rooms
// along its longer side, each with a door onto one of the corridors.
void Block(Rng& rng, Raster& raster, Building& b, size_t i, size_t j) {
  const double bx0 = b.xs[i] + b.xw[i] / 2, bx1 = b.xs[i + 1] - b.xw[i + 1] / 2;
  const double by0 = b.ys[j] + b.yw[j] / 2, by1 = b.ys[j + 1] - b.yw[j + 1] / 2;
  const bool along_x = bx1 - bx0 > by1 - by0;
  const int parts = std::clamp(static_cast<int>((along_x ? bx1 - bx0 : by1 - by0) / 4.0), 1, 3);
  for (int p = 0; p < parts; ++p) {
    Room r;
    const double a = p / static_cast<double>(parts), z = (p + 1) / static_cast<double>(parts);
    r.x0 = (along_x ? bx0 + a * (bx1 - bx0) : bx0) + kWall;
    r.x1 = (along_x ? bx0 + z * (bx1 - bx0) : bx1) - kWall;
    r.y0 = (along_x ? by0 : by0 + a * (by1 - by0)) + kWall;
    r.y1 = (along_x ? by1 : by0 + z * (by1 - by0)) - kWall;
    if (r.x1 - r.x0 < 1.8 || r.y1 - r.y0 < 1.8) continue;
    raster.Fill(r.x0, r.y0, r.x1, r.y1, false);
    // Sides: 0 bottom, 1 right, 2 top, 3 left; a room in a row along x
    // faces the corridors below and above, one along y those left and right.
    const int side = along_x ? 2 * rng.Int(0, 1) : 1 + 2 * rng.Int(0, 1);
    const double len = (side % 2 == 0) ? r.x1 - r.x0 : r.y1 - r.y0;
    const double at = rng.Uniform(0.3 + kDoor / 2, len - 0.3 - kDoor / 2);
    if (side == 0 || side == 2) {
      const double x = r.x0 + at, y = side == 0 ? by0 : by1;
      raster.Fill(x - kDoor / 2, y - kWall - 0.05, x + kDoor / 2, y + kWall + 0.05, false);
      r.door = {x, side == 0 ? r.y0 : r.y1};
      const size_t row = side == 0 ? j : j + 1;
      r.front = {x, b.ys[row]};
      r.edge = static_cast<int>(std::find(b.edges.begin(), b.edges.end(),
                                          std::make_pair(b.Node(i, row), b.Node(i + 1, row))) -
                                b.edges.begin());
    } else {
      const double y = r.y0 + at, x = side == 3 ? bx0 : bx1;
      raster.Fill(x - kWall - 0.05, y - kDoor / 2, x + kWall + 0.05, y + kDoor / 2, false);
      r.door = {side == 3 ? r.x0 : r.x1, y};
      const size_t col = side == 3 ? i : i + 1;
      r.front = {b.xs[col], y};
      r.edge = static_cast<int>(std::find(b.edges.begin(), b.edges.end(),
                                          std::make_pair(b.Node(col, j), b.Node(col, j + 1))) -
                                b.edges.begin());
    }
    Furnish(rng, raster, r, side);
    b.rooms.push_back(r);
  }
}

// Pillars and cabinets along the corridors' walls, clear of the crossings
// and of the doors, leaving the centre line free.
void CorridorClutter(Rng& rng, Raster& raster, const Building& b) {
  auto clear = [&](const Eigen::Vector2d& p) {
    for (const Room& r : b.rooms)
      if ((r.front - p).norm() < 1.5) return false;
    for (double x : b.xs)
      for (double y : b.ys)
        if ((Eigen::Vector2d(x, y) - p).norm() < 2.0) return false;
    return true;
  };
  for (int n = rng.Int(6, 20); n-- > 0;) {
    const bool vertical = rng.Int(0, 1);
    const size_t k = rng.Int(0, static_cast<int>((vertical ? b.xs : b.ys).size()) - 1);
    const double c = vertical ? b.xs[k] : b.ys[k], half = (vertical ? b.xw[k] : b.yw[k]) / 2;
    const double lo = vertical ? b.ys.front() : b.xs.front(),
                 hi = vertical ? b.ys.back() : b.xs.back();
    const double along = rng.Uniform(lo, hi), len = rng.Uniform(0.3, 1.0);
    const double depth = rng.Uniform(0.1, std::min(0.35, half - 0.5));
    const double side = rng.Int(0, 1) ? 1 : -1;
    const Eigen::Vector2d p = vertical ? Eigen::Vector2d(c, along) : Eigen::Vector2d(along, c);
    if (!clear(p) || depth <= 0.05) continue;
    const double a0 = side > 0 ? c + half - depth : c - half, a1 = a0 + depth;
    if (vertical)
      raster.Fill(a0, along, a1, along + len, true);
    else
      raster.Fill(along, a0, along + len, a1, true);
  }
}

Building MakeBuilding(Rng& rng, Raster** raster_out, std::unique_ptr<Raster>* keep) {
  Building b;
  b.width = rng.Uniform(24, 48);
  b.height = rng.Uniform(16, 32);
  // Blocks of 6 to 16 m between corridors.
  const int nx =
      rng.Int(std::max(2, static_cast<int>(b.width / 16) + 1), static_cast<int>(b.width / 8) + 1);
  const int ny = rng.Int(2, std::max(2, static_cast<int>(b.height / 8) + 1));
  Corridors(rng, nx, kMargin + 1.5, kMargin + b.width - 1.5, &b.xs, &b.xw);
  Corridors(rng, ny, kMargin + 1.5, kMargin + b.height - 1.5, &b.ys, &b.yw);
  *keep = std::make_unique<Raster>(b.width + 2 * kMargin, b.height + 2 * kMargin);
  Raster& raster = **keep;
  for (size_t i = 0; i < b.xs.size(); ++i)
    raster.Fill(b.xs[i] - b.xw[i] / 2, b.ys.front() - b.yw.front() / 2, b.xs[i] + b.xw[i] / 2,
                b.ys.back() + b.yw.back() / 2, false);
  for (size_t j = 0; j < b.ys.size(); ++j)
    raster.Fill(b.xs.front() - b.xw.front() / 2, b.ys[j] - b.yw[j] / 2,
                b.xs.back() + b.xw.back() / 2, b.ys[j] + b.yw[j] / 2, false);
  for (size_t j = 0; j < b.ys.size(); ++j)
    for (size_t i = 0; i < b.xs.size(); ++i) {
      if (i + 1 < b.xs.size()) b.edges.emplace_back(b.Node(i, j), b.Node(i + 1, j));
      if (j + 1 < b.ys.size()) b.edges.emplace_back(b.Node(i, j), b.Node(i, j + 1));
    }
  for (size_t j = 0; j + 1 < b.ys.size(); ++j)
    for (size_t i = 0; i + 1 < b.xs.size(); ++i) Block(rng, raster, b, i, j);
  CorridorClutter(rng, raster, b);
  *raster_out = &raster;
  return b;
}

// A walk over the corridor graph, least-travelled edge first, into some of
// the rooms it passes, until `length` metres: the waypoints.
std::vector<Eigen::Vector2d> Route(Rng& rng, const Building& b, double length) {
  const int nodes = static_cast<int>(b.xs.size() * b.ys.size());
  std::vector<int> travelled(b.edges.size(), 0);
  int at = rng.Int(0, nodes - 1);
  std::vector<Eigen::Vector2d> route{b.At(at)};
  double total = 0;
  while (total < length) {
    std::vector<int> options;
    int fewest = 1 << 30;
    for (size_t e = 0; e < b.edges.size(); ++e)
      if (b.edges[e].first == at || b.edges[e].second == at) {
        if (travelled[e] < fewest) options.clear();
        if (travelled[e] <= fewest) options.push_back(static_cast<int>(e)), fewest = travelled[e];
      }
    const int e = options[rng.Int(0, static_cast<int>(options.size()) - 1)];
    ++travelled[e];
    const int next = b.edges[e].first == at ? b.edges[e].second : b.edges[e].first;
    const Eigen::Vector2d from = b.At(at), to = b.At(next);
    std::vector<const Room*> on;
    for (const Room& r : b.rooms)
      if (r.edge == e && rng.Uniform(0, 1) < 0.35) on.push_back(&r);
    std::sort(on.begin(), on.end(), [&](const Room* a, const Room* c) {
      return (a->front - from).norm() < (c->front - from).norm();
    });
    for (const Room* r : on) {
      const Eigen::Vector2d inward = (r->door - r->front).normalized();
      const Eigen::Vector2d centre((r->x0 + r->x1) / 2, (r->y0 + r->y1) / 2);
      for (const Eigen::Vector2d& p : {r->front, Eigen::Vector2d(r->door + 0.6 * inward), centre,
                                       Eigen::Vector2d(r->door + 0.6 * inward), r->front}) {
        total += (p - route.back()).norm();
        route.push_back(p);
      }
    }
    total += (to - route.back()).norm();
    route.push_back(to);
    at = next;
  }
  return route;
}

// Drives the route (turning on the spot where the heading is far off, else
// steering while moving) and keeps a pose every scan_spacing metres or
// scan_turn radians.
std::vector<SE2> Drive(const std::vector<Eigen::Vector2d>& route, const LaserSimulationOptions& o) {
  const double dt = 0.05, v_max = 0.6, w_max = 0.8;
  Eigen::Vector2d d =
      route.size() > 1 ? Eigen::Vector2d(route[1] - route[0]) : Eigen::Vector2d(1, 0);
  SE2 pose(route[0].x(), route[0].y(), std::atan2(d.y(), d.x()));
  std::vector<SE2> scans{pose};
  double moved = 0, turned = 0;
  for (size_t k = 1; k < route.size();) {
    const Eigen::Vector2d to = route[k] - pose.translation();
    if (to.norm() < 0.05) {
      ++k;
      continue;
    }
    const double err = NormalizeAngle(std::atan2(to.y(), to.x()) - pose.theta());
    const double w = std::clamp(2.0 * err, -w_max, w_max);
    const double v = std::abs(err) > 0.3 ? 0.0 : std::min(v_max, to.norm() / dt);
    pose = pose * SE2(v * dt * std::cos(w * dt / 2), v * dt * std::sin(w * dt / 2), w * dt);
    moved += v * dt;
    turned += std::abs(w * dt);
    if (moved >= o.scan_spacing || turned >= o.scan_turn) {
      scans.push_back(pose);
      moved = turned = 0;
    }
  }
  return scans;
}

std::vector<float> Scan(const Raster& raster, const SE2& pose, const LaserSimulationOptions& o,
                        Rng& rng) {
  std::vector<float> ranges(o.beams);
  const double step = o.fov / (o.beams - 1);
  for (int b = 0; b < o.beams; ++b) {
    const double r =
        raster.Cast(pose.x(), pose.y(), pose.theta() - o.fov / 2 + b * step, o.max_range);
    ranges[b] = static_cast<float>(
        r >= o.max_range ? o.max_range
                         : std::clamp(r + rng.Normal(o.range_noise), 0.0, o.max_range - 0.01));
  }
  return ranges;
}

// Wheel odometry of each step: a systematic error drawn once, and noise.
std::vector<SE2> Odometry(const std::vector<SE2>& truth, const LaserSimulationOptions& o,
                          Rng& rng) {
  const double scale = 1 + rng.Uniform(-o.scale_error, o.scale_error);
  const double turn_scale = 1 + rng.Uniform(-o.turn_scale_error, o.turn_scale_error);
  const double bias = rng.Uniform(-o.heading_bias_per_m, o.heading_bias_per_m);
  std::vector<SE2> odometry{SE2()};
  for (size_t k = 1; k < truth.size(); ++k) {
    const SE2 u = truth[k - 1].Between(truth[k]);
    const double d = u.translation().norm();
    const double sigma = o.translation_noise * d + 0.002;
    odometry.emplace_back(scale * u.x() + rng.Normal(sigma),
                          scale * u.y() + rng.Normal(0.5 * sigma),
                          NormalizeAngle(turn_scale * u.theta() + bias * d +
                                         rng.Normal(o.rotation_noise * std::abs(u.theta()) +
                                                    o.heading_noise_per_m * d + 0.002)));
  }
  return odometry;
}

}  // namespace

LaserSimulation SimulateLaserLog(const LaserSimulationOptions& options) {
  Rng rng(options.seed);
  Raster* raster = nullptr;
  std::unique_ptr<Raster> keep;
  const Building building = MakeBuilding(rng, &raster, &keep);
  LaserSimulation sim;
  sim.options = options;
  sim.width = building.width + 2 * kMargin;
  sim.height = building.height + 2 * kMargin;
  sim.truth = Drive(Route(rng, building, options.path_length), options);
  for (const SE2& pose : sim.truth) sim.ranges.push_back(Scan(*raster, pose, options, rng));
  sim.odometry = Odometry(sim.truth, options, rng);
  return sim;
}

void WriteCarmenLog(const LaserSimulation& sim, std::ostream& os) {
  const LaserSimulationOptions& o = sim.options;
  const double deg = 180 / M_PI;
  char buf[128];
  os << "# simulated: seed " << o.seed << "; the FLASER lines' poses are the ground truth\n";
  std::snprintf(buf, sizeof buf, "PARAM laser_front_laser_fov %.9g nohost 0\n", o.fov * deg);
  os << buf;
  std::snprintf(buf, sizeof buf, "PARAM laser_front_laser_resolution %.9g nohost 0\n",
                o.fov * deg / (o.beams - 1));
  os << buf;
  std::snprintf(buf, sizeof buf, "PARAM robot_front_laser_max %.9g nohost 0\n", o.max_range);
  os << buf;
  auto pose = [&](const SE2& p) {
    std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f", p.x(), p.y(), p.theta());
    return std::string(buf);
  };
  for (size_t k = 0; k < sim.truth.size(); ++k) {
    const double t = 0.5 * static_cast<double>(k);
    std::snprintf(buf, sizeof buf, "%.3f", t);
    const std::string stamp = buf;
    if (k > 0)
      os << "ODOM " << pose(sim.truth[k - 1] * sim.odometry[k]) << " 0 0 0 " << stamp << " sim "
         << stamp << "\n";
    os << "FLASER " << sim.ranges[k].size();
    for (float r : sim.ranges[k]) {
      std::snprintf(buf, sizeof buf, " %.3f", r);
      os << buf;
    }
    os << " " << pose(sim.truth[k]) << " " << pose(sim.truth[k]) << " " << stamp << " sim " << stamp
       << "\n";
  }
}

}  // namespace cairn::frontend
