#include "cairn/frontend/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace cairn::frontend {

OccupancyGrid::OccupancyGrid(const Eigen::Vector2d& min, const Eigen::Vector2d& max,
                             const GridOptions& options)
    : o_(options), origin_(min) {
  if (!(options.resolution > 0)) throw std::invalid_argument("grid resolution must be positive");
  w_ = std::max(1, static_cast<int>(std::ceil((max.x() - min.x()) / o_.resolution)));
  h_ = std::max(1, static_cast<int>(std::ceil((max.y() - min.y()) / o_.resolution)));
  if (static_cast<double>(w_) * h_ > 4e8) throw std::invalid_argument("grid too large");
  lo_.assign(static_cast<size_t>(w_) * h_, 0.f);
  known_.assign(lo_.size(), 0);
}

bool OccupancyGrid::Cell(const Eigen::Vector2d& p, int* cx, int* cy) const {
  *cx = static_cast<int>(std::floor((p.x() - origin_.x()) / o_.resolution));
  *cy = static_cast<int>(std::floor((p.y() - origin_.y()) / o_.resolution));
  return *cx >= 0 && *cy >= 0 && *cx < w_ && *cy < h_;
}

namespace {

// Bresenham: every cell from (x0, y0) on towards (x1, y1), that one excluded.
template <typename Visit>
void WalkCells(int x0, int y0, int x1, int y1, Visit visit) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy, x = x0, y = y0;
  while (x != x1 || y != y1) {
    visit(x, y);
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y += sy;
    }
  }
}

}  // namespace

void OccupancyGrid::Add(int cx, int cy, float delta) {
  if (cx < 0 || cy < 0 || cx >= w_ || cy >= h_) return;
  const size_t i = static_cast<size_t>(cy) * w_ + cx;
  lo_[i] = std::clamp(lo_[i] + delta, static_cast<float>(-o_.clamp), static_cast<float>(o_.clamp));
  known_[i] = 1;
}

void OccupancyGrid::AddBeam(const Eigen::Vector2d& origin, const Eigen::Vector2d& end, bool hit) {
  int x0, y0, x1, y1;
  Cell(origin, &x0, &y0);
  Cell(end, &x1, &y1);
  const float miss = static_cast<float>(o_.log_odds_miss);
  WalkCells(x0, y0, x1, y1, [&](int x, int y) { Add(x, y, miss); });
  Add(x1, y1, hit ? static_cast<float>(o_.log_odds_hit) : miss);
}

void OccupancyGrid::AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  int x0, y0, x1, y1;
  Cell(a, &x0, &y0);
  Cell(b, &x1, &y1);
  const float hit = static_cast<float>(o_.log_odds_hit);
  WalkCells(x0, y0, x1, y1, [&](int x, int y) {
    if (x != x0 || y != y0) Add(x, y, hit);
  });
}

double OccupancyGrid::Probability(int cx, int cy) const {
  return 1.0 - 1.0 / (1.0 + std::exp(LogOdds(cx, cy)));
}

Image OccupancyGrid::ToTrinary() const {
  Image img{w_, h_, 1, std::vector<uint8_t>(static_cast<size_t>(w_) * h_, 205)};
  for (int y = 0; y < h_; ++y)
    for (int x = 0; x < w_; ++x) {
      if (!Known(x, y)) continue;
      const double p = Probability(x, y);
      uint8_t v = 205;
      if (p > 0.65) v = 0;
      else if (p < 0.196) v = 254;
      img.pixels[static_cast<size_t>(h_ - 1 - y) * w_ + x] = v;
    }
  return img;
}

Image OccupancyGrid::ToGray() const {
  Image img{w_, h_, 1, std::vector<uint8_t>(static_cast<size_t>(w_) * h_, 200)};
  for (int y = 0; y < h_; ++y)
    for (int x = 0; x < w_; ++x) {
      if (!Known(x, y)) continue;
      const double p = Probability(x, y);
      img.pixels[static_cast<size_t>(h_ - 1 - y) * w_ + x] =
          static_cast<uint8_t>(std::lround(255 * (1 - p)));
    }
  return img;
}

std::string OccupancyGrid::Yaml(const std::string& image_file) const {
  std::ostringstream os;
  os.precision(10);
  os << "image: " << image_file << "\nresolution: " << o_.resolution << "\norigin: ["
     << origin_.x() << ", " << origin_.y() << ", 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
     << "free_thresh: 0.196\n";
  return os.str();
}

}  // namespace cairn::frontend
