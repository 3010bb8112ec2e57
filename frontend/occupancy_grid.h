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
  double max_clear_range = 15.0; // how far a no-return beam clears
};

class OccupancyGrid {
 public:
  // Covers [min, max] (metres) in the world frame.
  OccupancyGrid(const Eigen::Vector2d& min, const Eigen::Vector2d& max, const GridOptions& options);

  // One beam from `origin` to `end`; `hit` false for a no-return beam
  // (then `end` is where clearing stops).
  void AddBeam(const Eigen::Vector2d& origin, const Eigen::Vector2d& end, bool hit);

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
  GridOptions o_;
  Eigen::Vector2d origin_;
  int w_, h_;
  std::vector<float> lo_;
  std::vector<char> known_;
};

}  // namespace cairn::frontend
