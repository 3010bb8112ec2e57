// Occupancy grid mapping with known poses: independent cells holding
// log-odds, updated along each beam by an inverse sensor model (free up to
// the hit, occupied at it; beams at maximum range only clear).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/frontend/image_io.h"

namespace cairn::frontend {

struct GridOptions {
  double resolution = 0.05;
  double log_odds_hit = 0.85;    // ~ p 0.7
  double log_odds_miss = -0.4;   // ~ p 0.4
  double clamp = 5.0;            // saturation, so that cells can still change
  // How far a no-return beam clears; 0: not at all. Short, since no return
  // is as often glass, a door or a dark surface as open space, and a map
  // with free space outside the building leads a planner out through walls.
  double max_clear_range = 3.0;
  // Consecutive hits of one scan closer than this are joined by occupied
  // cells, so that beams spread apart at range leave no gaps in a wall; a
  // doorway is wider.
  double max_wall_gap = 0.3;
};

class OccupancyGrid {
 public:
  // Covers [min, max] (metres) in the world frame.
  OccupancyGrid(const Eigen::Vector2d& min, const Eigen::Vector2d& max, const GridOptions& options);

  // One beam from `origin` to `end`; `hit` false for a no-return beam
  // (then `end` is where clearing stops).
  void AddBeam(const Eigen::Vector2d& origin, const Eigen::Vector2d& end, bool hit);
  // Marks the cells strictly between two hits of one scan occupied (as one
  // hit each), for a wall the beams between them would have seen.
  void AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b);

  int width() const { return w_; }
  int height() const { return h_; }
  double resolution() const { return o_.resolution; }
  Eigen::Vector2d origin() const { return origin_; }  // lower-left corner of cell (0, 0)
  bool Cell(const Eigen::Vector2d& p, int* cx, int* cy) const;
  float LogOdds(int cx, int cy) const { return lo_[static_cast<size_t>(cy) * w_ + cx]; }
  double Probability(int cx, int cy) const;
  bool Known(int cx, int cy) const { return known_[static_cast<size_t>(cy) * w_ + cx] != 0; }

  // map_server's trinary image: 0 occupied (p > 0.65), 254 free (p < 0.196),
  // 205 unknown; top row is the largest y.
  Image ToTrinary() const;
  // Grey levels by probability, unknown in a neutral tone, for people.
  Image ToGray() const;
  // The map_server YAML that goes with `image_file`.
  std::string Yaml(const std::string& image_file) const;

 private:
  // One cell's log-odds by `delta`, clamped; cells outside the grid are skipped.
  void Add(int cx, int cy, float delta);

  GridOptions o_;
  Eigen::Vector2d origin_;
  int w_, h_;
  std::vector<float> lo_;
  std::vector<char> known_;
};

}  // namespace cairn::frontend
