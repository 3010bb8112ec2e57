#include "cairn/frontend/scan_matcher.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace cairn::frontend {

void PointCloud::Append(const PointCloud& other, const SE2& pose) {
  const Eigen::Matrix2d R = pose.rotation();
  const Eigen::Vector2d t = pose.translation();
  points.reserve(points.size() + other.size());
  for (size_t i = 0; i < other.size(); ++i) {
    points.push_back(R * other.points[i] + t);
    normals.push_back(R * other.normals[i]);
    has_normal.push_back(other.has_normal[i]);
  }
}

PointCloud ScanToCloud(const LaserScan& scan, double min_range, double max_range) {
  const size_t n = scan.ranges.size();
  std::vector<Eigen::Vector2d> pts(n);
  std::vector<char> valid(n, 0);
  const Eigen::Vector2d sensor = scan.laser_offset.translation();
  for (size_t i = 0; i < n; ++i) {
    const double r = scan.ranges[i];
    if (!(r > min_range && r < max_range)) continue;
    const double a = scan.angle_min + scan.angle_increment * i;
    pts[i] = scan.laser_offset * Eigen::Vector2d(r * std::cos(a), r * std::sin(a));
    valid[i] = 1;
  }
  PointCloud out;
  for (size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    // Neighbours along the scan that lie on the same surface: the gap
    // allowed grows with range, since beams spread apart.
    const double r = scan.ranges[i];
    const double gap = std::max(0.1, 3.0 * r * scan.angle_increment);
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    std::vector<Eigen::Vector2d> nb;
    for (int k = -3; k <= 3; ++k) {
      const long j = static_cast<long>(i) + k;
      if (j < 0 || j >= static_cast<long>(n) || !valid[j]) continue;
      if ((pts[j] - pts[i]).norm() > gap * std::max(1, std::abs(k))) continue;
      nb.push_back(pts[j]);
      mean += pts[j];
    }
    Eigen::Vector2d normal = Eigen::Vector2d::Zero();
    bool ok = false;
    if (nb.size() >= 4) {
      mean /= nb.size();
      Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
      for (const auto& p : nb) cov += (p - mean) * (p - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
      // A line, not a blob: the spread across must be small beside the spread along.
      if (es.eigenvalues()[0] < 0.1 * es.eigenvalues()[1]) {
        normal = es.eigenvectors().col(0);
        if (normal.dot(sensor - pts[i]) < 0) normal = -normal;
        ok = true;
      }
    }
    out.points.push_back(pts[i]);
    out.normals.push_back(normal);
    out.has_normal.push_back(ok);
  }
  return out;
}

PointCloud Downsample(const PointCloud& cloud, double cell) {
  PointCloud out;
  std::unordered_set<long long> seen;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const long long cx = static_cast<long long>(std::floor(cloud.points[i].x() / cell));
    const long long cy = static_cast<long long>(std::floor(cloud.points[i].y() / cell));
    if (!seen.insert(cx * 73856093LL ^ cy * 19349663LL).second) continue;
    out.points.push_back(cloud.points[i]);
    out.normals.push_back(cloud.normals[i]);
    out.has_normal.push_back(cloud.has_normal[i]);
  }
  return out;
}

MatchMap::MatchMap(const PointCloud& world, double resolution, double radius, double sigma)
    : cloud_(world), res_(resolution) {
  if (world.points.empty()) {
    origin_ = Eigen::Vector2d::Zero();
    return;
  }
  Eigen::Vector2d lo = world.points[0], hi = world.points[0];
  for (const auto& p : world.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double margin = radius + 2 * res_;
  origin_ = lo - Eigen::Vector2d(margin, margin);
  w_ = static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * margin) / res_)) + 1;
  h_ = static_cast<int>(std::ceil((hi.y() - lo.y() + 2 * margin) / res_)) + 1;
  bw_ = (w_ + kBlockSide - 1) / kBlockSide;
  const int bh = (h_ + kBlockSide - 1) / kBlockSide;
  dir_.assign(static_cast<size_t>(bw_) * bh, -1);
  int blocks = 0;
  auto slot = [&](int x, int y) {
    int& b = dir_[static_cast<size_t>(y >> kBlockBits) * bw_ + (x >> kBlockBits)];
    if (b < 0) {
      b = blocks++;
      like_.resize(like_.size() + kBlockSide * kBlockSide, 0.f);
      nearest_.resize(nearest_.size() + kBlockSide * kBlockSide, -1);
    }
    return Slot(b, x, y);
  };
  // The likelihood falls with distance, so the highest one seen in a cell
  // also names its nearest point: one pass, no per-cell distance array.
  const int rc = static_cast<int>(std::ceil(radius / res_));
  const double r2 = radius * radius;
  const double inv = 1.0 / (2 * sigma * sigma);
  // The Gaussian separates: exp(-(dx^2 + dy^2)) = exp(-dx^2) exp(-dy^2), so
  // a point costs 2 (2 rc + 1) exponentials rather than one per cell.
  std::vector<double> ex(2 * rc + 1), ey(2 * rc + 1), dx2(2 * rc + 1);
  for (size_t k = 0; k < world.size(); ++k) {
    const Eigen::Vector2d c = (world.points[k] - origin_) / res_;
    const int cx = static_cast<int>(std::floor(c.x())), cy = static_cast<int>(std::floor(c.y()));
    for (int o = -rc; o <= rc; ++o) {
      const double dx = (cx + o + 0.5 - c.x()) * res_, dy = (cy + o + 0.5 - c.y()) * res_;
      dx2[o + rc] = dx * dx;
      ex[o + rc] = std::exp(-dx * dx * inv);
      ey[o + rc] = std::exp(-dy * dy * inv);
    }
    for (int y = std::max(0, cy - rc); y <= std::min(h_ - 1, cy + rc); ++y) {
      const double dy = (y + 0.5 - c.y()) * res_;
      for (int x = std::max(0, cx - rc); x <= std::min(w_ - 1, cx + rc); ++x) {
        const double d2 = dx2[x - cx + rc] + dy * dy;
        if (d2 >= r2) continue;
        const size_t i = slot(x, y);
        // Strictly above zero even far out, so that any point in range wins
        // over an empty cell.
        const float l = std::max(static_cast<float>(ex[x - cx + rc] * ey[y - cy + rc]), 1e-30f);
        if (l > like_[i]) {
          like_[i] = l;
          nearest_[i] = static_cast<int>(k);
        }
      }
    }
  }
}

void MatchMap::BuildPyramid(int levels) const {
  levels = std::min(levels, kBlockBits);
  if (levels > 0 && pdir_.empty()) {
    // The squares reach up to 15 cells up and right: the blocks below and
    // left of a filled one hold pooled values too.
    const int bh = bw_ ? static_cast<int>(dir_.size()) / bw_ : 0;
    pdir_.assign(dir_.size(), -1);
    for (int by = 0; by < bh; ++by)
      for (int bx = 0; bx < bw_; ++bx) {
        bool near = false;
        for (int k = 0; k < 4 && !near; ++k) {
          const int x = bx + (k & 1), y = by + (k >> 1);
          near = x < bw_ && y < bh && dir_[static_cast<size_t>(y) * bw_ + x] >= 0;
        }
        if (!near) continue;
        pdir_[static_cast<size_t>(by) * bw_ + bx] = static_cast<int>(block_pos_.size());
        block_pos_.emplace_back(bx, by);
      }
  }
  const size_t cells = block_pos_.size() * kBlockSide * kBlockSide;
  for (int l = static_cast<int>(pooled_.size()) + 1; l <= levels; ++l) {
    // Level l from level l - 1: the square of side 2^l is four of side 2^(l-1).
    const int h = 1 << (l - 1);
    std::vector<float> next(cells, 0.f);
    for (size_t b = 0; b < block_pos_.size(); ++b) {
      const int x0 = block_pos_[b].first << kBlockBits, y0 = block_pos_[b].second << kBlockBits;
      for (int y = y0; y < y0 + kBlockSide; ++y)
        for (int x = x0; x < x0 + kBlockSide; ++x)
          next[Slot(static_cast<int>(b), x, y)] =
              std::max(std::max(PooledAtCell(l - 1, x, y), PooledAtCell(l - 1, x + h, y)),
                       std::max(PooledAtCell(l - 1, x, y + h), PooledAtCell(l - 1, x + h, y + h)));
    }
    pooled_.push_back(std::move(next));
  }
}

int MatchMap::Nearest(const Eigen::Vector2d& p) const {
  const int cx = static_cast<int>(std::floor((p.x() - origin_.x()) / res_));
  const int cy = static_cast<int>(std::floor((p.y() - origin_.y()) / res_));
  if (cx < 0 || cy < 0 || cx >= w_ || cy >= h_) return -1;
  const int b = dir_[static_cast<size_t>(cy >> kBlockBits) * bw_ + (cx >> kBlockBits)];
  return b < 0 ? -1 : nearest_[Slot(b, cx, cy)];
}

namespace {

struct Candidate {
  double score = -1;
  double theta = 0;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
};

// The distance over which the pull to the guess grows to its full size.
double PenaltyScale(double penalty_window, double window) {
  return std::max(penalty_window > 0 ? penalty_window : window, 1e-6);
}

// ArcMisfit of a move whose turn and chord (in the start's frame) are known.
double MoveMisfit(double turn, const Eigen::Vector2d& local) {
  double misfit = std::clamp((std::abs(turn) - M_PI / 2) / (M_PI / 2), 0.0, 1.0);
  const double length = local.norm();
  constexpr double kShortest = 0.1, kFull = 0.4;  // metres: the way not judged, judged fully
  if (length > kShortest) {
    const double off = std::abs(NormalizeAngle(std::atan2(local.y(), local.x()) - 0.5 * turn));
    constexpr double kFullOff = 1.05;  // 60 degrees: a half-turned twin is near 90
    // Bases drive backwards too, but seldom: such a move is half a misfit.
    constexpr double kBackwards = 0.5;
    const double way = std::min(off / kFullOff, kBackwards + (M_PI - off) / kFullOff);
    const double weight = std::min(1.0, (length - kShortest) / (kFull - kShortest));
    misfit = std::max(misfit, weight * std::min(1.0, way));
  }
  return misfit;
}

// Moves from one pose judged by ArcMisfit, the pose's inverse taken once
// for the many poses a search scores.
class ArcJudge {
 public:
  explicit ArcJudge(const SE2& from)
      : inverse_(from.Inverse()), rotation_(inverse_.rotation()), theta_(from.theta()) {}
  double Misfit(double theta, const Eigen::Vector2d& t) const {
    return MoveMisfit(NormalizeAngle(theta - theta_), inverse_.translation() + rotation_ * t);
  }

 private:
  SE2 inverse_;
  Eigen::Matrix2d rotation_;
  double theta_;
};

// The factor on a pose's score for its move from CorrelativeOptions::arc_from
// (1 when its penalty is off).
class ArcFit {
 public:
  explicit ArcFit(const CorrelativeOptions& o) : penalty_(o.arc_penalty), judge_(o.arc_from) {}
  double operator()(double theta, const Eigen::Vector2d& t) const {
    if (penalty_ <= 0) return 1;
    const double misfit = judge_.Misfit(theta, t);
    return 1 - penalty_ * misfit * misfit;
  }

 private:
  double penalty_;
  ArcJudge judge_;
};

// Scores every (theta, dx, dy) with theta in `angles` and translations on
// the map's grid within +-n cells of `center`.
void Search(const MatchMap& map, const std::vector<Eigen::Vector2d>& scan,
            const std::vector<double>& angles, const Eigen::Vector2d& center, int n,
            const SE2& guess, const CorrelativeOptions& o, Candidate* best) {
  const ArcFit arc_fit(o);
  const double res = map.resolution();
  std::vector<int> cx(scan.size()), cy(scan.size());
  const double inv_n = 1.0 / std::max<size_t>(1, scan.size());
  std::vector<double> sums(static_cast<size_t>(2 * n + 1) * (2 * n + 1));
  for (double theta : angles) {
    const double c = std::cos(theta), s = std::sin(theta);
    for (size_t i = 0; i < scan.size(); ++i) {
      const Eigen::Vector2d q(c * scan[i].x() - s * scan[i].y() + center.x() - map.origin().x(),
                              s * scan[i].x() + c * scan[i].y() + center.y() - map.origin().y());
      cx[i] = static_cast<int>(std::floor(q.x() / res));
      cy[i] = static_cast<int>(std::floor(q.y() / res));
    }
    std::fill(sums.begin(), sums.end(), 0.0);
    for (int dy = -n; dy <= n; ++dy)
      for (int dx = -n; dx <= n; ++dx) {
        double sum = 0;
        for (size_t i = 0; i < scan.size(); ++i) sum += map.LikelihoodAtCell(cx[i] + dx, cy[i] + dy);
        sums[static_cast<size_t>(dy + n) * (2 * n + 1) + dx + n] = sum;
      }
    const double da = NormalizeAngle(theta - guess.theta()) / PenaltyScale(o.penalty_angular_window, o.angular_window);
    for (int dy = -n; dy <= n; ++dy)
      for (int dx = -n; dx <= n; ++dx) {
        const Eigen::Vector2d t = center + Eigen::Vector2d(dx * res, dy * res);
        const double dl = (t - guess.translation()).norm() / PenaltyScale(o.penalty_linear_window, o.linear_window);
        const double score = sums[static_cast<size_t>(dy + n) * (2 * n + 1) + dx + n] * inv_n *
                             (1 - o.distance_penalty * std::min(1.0, dl * dl)) *
                             (1 - o.distance_penalty * std::min(1.0, da * da)) * arc_fit(theta, t);
        if (score > best->score) *best = {score, theta, t};
      }
  }
}

// The coarse level's search space: every angle of `angles` and every
// translation within +-n cells of `center`, each scan point's cell at zero
// offset per angle.
struct SearchSpace {
  std::vector<double> angles;
  std::vector<std::vector<int>> cx, cy;  // per angle, per point
  Eigen::Vector2d center;
  int n = 0;
};

SearchSpace MakeSpace(const MatchMap& map, const std::vector<Eigen::Vector2d>& scan,
                      std::vector<double> angles, const Eigen::Vector2d& center, int n) {
  SearchSpace sp;
  sp.center = center;
  sp.n = n;
  const double res = map.resolution();
  for (double theta : angles) {
    const double c = std::cos(theta), s = std::sin(theta);
    std::vector<int> cx(scan.size()), cy(scan.size());
    for (size_t i = 0; i < scan.size(); ++i) {
      cx[i] = static_cast<int>(std::floor(
          (c * scan[i].x() - s * scan[i].y() + center.x() - map.origin().x()) / res));
      cy[i] = static_cast<int>(std::floor(
          (s * scan[i].x() + c * scan[i].y() + center.y() - map.origin().y()) / res));
    }
    sp.cx.push_back(std::move(cx));
    sp.cy.push_back(std::move(cy));
  }
  sp.angles = std::move(angles);
  return sp;
}

// A square of 2^level x 2^level translations from offset (x, y) up, at one angle.
struct Node {
  double bound;
  int angle, x, y, level;
  bool operator<(const Node& o) const { return bound < o.bound; }
};

// Branch and bound (as in Hess et al. 2016's real-time loop closure): a
// node's pooled score bounds every translation in its square, so squares
// are split best first and those below the best found are never scored
// exactly. Returns the exactly scored poses whose score reached `floor`
// times the best at that moment (the best among them), for the runner-up.
std::vector<Candidate> BranchAndBound(const MatchMap& map, const SearchSpace& sp, const SE2& guess,
                                      const CorrelativeOptions& o, double floor) {
  const ArcFit arc_fit(o);
  const int span = 2 * sp.n + 1;
  int top = 0;
  while (top < 4 && (span >> top) > 4) ++top;
  map.BuildPyramid(top);
  top = std::min(top, map.pyramid_levels());
  const size_t np = sp.cx.empty() ? 0 : sp.cx[0].size();
  const double inv_n = 1.0 / std::max<size_t>(1, np);
  auto sum = [&](int a, int level, int x, int y) {
    double total = 0;
    const std::vector<int>&cx = sp.cx[a], &cy = sp.cy[a];
    for (size_t i = 0; i < np; ++i) total += map.PooledAtCell(level, cx[i] + x, cy[i] + y);
    return total * inv_n;
  };
  std::vector<Node> heap;
  for (int a = 0; a < static_cast<int>(sp.angles.size()); ++a)
    for (int y = -sp.n; y <= sp.n; y += 1 << top)
      for (int x = -sp.n; x <= sp.n; x += 1 << top) heap.push_back({sum(a, top, x, y), a, x, y, top});
  std::make_heap(heap.begin(), heap.end());
  std::vector<Candidate> scored;
  double best = -1;
  const double res = map.resolution();
  while (!heap.empty() && heap.front().bound >= std::max(0.0, floor * best)) {
    std::pop_heap(heap.begin(), heap.end());
    const Node node = heap.back();
    heap.pop_back();
    if (node.level == 0) {
      // Exact: the same sum the exhaustive search takes, with its pull to the guess.
      const double theta = sp.angles[node.angle];
      const Eigen::Vector2d t = sp.center + Eigen::Vector2d(node.x * res, node.y * res);
      const double da = NormalizeAngle(theta - guess.theta()) / PenaltyScale(o.penalty_angular_window, o.angular_window);
      const double dl = (t - guess.translation()).norm() / PenaltyScale(o.penalty_linear_window, o.linear_window);
      const double score = node.bound * (1 - o.distance_penalty * std::min(1.0, dl * dl)) *
                           (1 - o.distance_penalty * std::min(1.0, da * da)) * arc_fit(theta, t);
      if (score >= floor * best) scored.push_back({score, theta, t});
      best = std::max(best, score);
      continue;
    }
    const int h = 1 << (node.level - 1);
    for (int k = 0; k < 4; ++k) {
      const int x = node.x + (k & 1) * h, y = node.y + (k >> 1) * h;
      if (x > sp.n || y > sp.n) continue;
      heap.push_back({sum(node.angle, node.level - 1, x, y), node.angle, x, y, node.level - 1});
      std::push_heap(heap.begin(), heap.end());
    }
  }
  return scored;
}

// The mean likelihood of the scan at one pose, on the map's grid.
double ScorePose(const MatchMap& map, const std::vector<Eigen::Vector2d>& scan, double theta,
                 const Eigen::Vector2d& t) {
  const double c = std::cos(theta), s = std::sin(theta), res = map.resolution();
  double sum = 0;
  for (const auto& p : scan)
    sum += map.LikelihoodAtCell(
        static_cast<int>(std::floor((c * p.x() - s * p.y() + t.x() - map.origin().x()) / res)),
        static_cast<int>(std::floor((s * p.x() + c * p.y() + t.y() - map.origin().y()) / res)));
  return scan.empty() ? 0 : sum / scan.size();
}

// Whether the straight way from `a` to `b` at a's heading keeps the score
// up (no dip below `share` of the lower end): the two lie on one ridge, as
// poses along a corridor do, not on two separate peaks.
bool OnOneRidge(const MatchMap& map, const std::vector<Eigen::Vector2d>& scan, const Candidate& a,
                const Candidate& b, double share) {
  const double low = share * std::min(a.score, b.score);
  const int steps = std::max(2, static_cast<int>(std::ceil((b.t - a.t).norm() / map.resolution())));
  for (int k = 1; k < steps; ++k)
    if (ScorePose(map, scan, a.theta, a.t + (b.t - a.t) * (static_cast<double>(k) / steps)) < low)
      return false;
  return true;
}

struct BestAndSecond {
  Candidate best, second;  // second: the best when none is distinct
  double ratio = 1;        // second's score over best's
};

// The best of the scored poses, and the best of those distinct from it
// (over the best's score; at most the floor when none reached it).
BestAndSecond BestAndRunnerUp(const MatchMap& map, const std::vector<Eigen::Vector2d>& scan,
                              std::vector<Candidate> scored, const CorrelativeOptions& o) {
  std::sort(scored.begin(), scored.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  const Candidate best = scored.empty() ? Candidate{} : scored.front();
  Candidate second = best;
  double runner_up = 0;
  int ridge_checks = 0;
  for (const Candidate& c : scored) {
    const bool turned =
        o.runner_up_angle > 0 && std::abs(NormalizeAngle(c.theta - best.theta)) > o.runner_up_angle;
    if (!turned && (c.t - best.t).norm() <= o.runner_up_distance) continue;
    // Same heading, somewhere along the best's ridge: not another place.
    if (!turned && o.ridge_share > 0 && std::abs(NormalizeAngle(c.theta - best.theta)) < 0.05 &&
        ridge_checks++ < 50 && OnOneRidge(map, scan, best, c, o.ridge_share))
      continue;
    runner_up = c.score;
    second = c;
    break;
  }
  const double ratio = best.score > 0 ? runner_up / best.score : 1.0;
  return {best, second, o.runner_up_distance > 0 ? std::min(1.0, ratio) : 1.0};
}

}  // namespace

// On an arc of turn dth the chord leaves at dth/2 (driven backwards, at
// dth/2 + pi); and a base turns less than a quarter turn between scans, a
// half turn never.
double ArcMisfit(const SE2& from, const SE2& to) {
  return ArcJudge(from).Misfit(to.theta(), to.translation());
}

CorrelativeResult CorrelativeMatch(const MatchMap& coarse, const MatchMap& fine,
                                   const std::vector<Eigen::Vector2d>& scan, const SE2& guess,
                                   const CorrelativeOptions& o) {
  Candidate best;
  std::vector<double> angles;
  const double coarse_step = 2 * o.angular_step;
  const int na = static_cast<int>(std::ceil(o.angular_window / coarse_step));
  for (int k = -na; k <= na; ++k) angles.push_back(guess.theta() + k * coarse_step);
  const int n = static_cast<int>(std::ceil(o.linear_window / coarse.resolution()));
  const SearchSpace space = MakeSpace(coarse, scan, angles, guess.translation(), n);
  // Without a runner-up to find, only the best matters: nothing below it is split.
  const double floor = o.runner_up_distance > 0 ? o.runner_up_floor : 1.0;
  const BestAndSecond coarse_best =
      BestAndRunnerUp(coarse, scan, BranchAndBound(coarse, space, guess, o, floor), o);
  best = coarse_best.best;
  angles.clear();
  for (int k = -2; k <= 2; ++k) angles.push_back(best.theta + k * 0.5 * o.angular_step);
  const int nf = static_cast<int>(std::ceil(coarse.resolution() / fine.resolution()));
  Candidate fine_best;
  Search(fine, scan, angles, best.t, nf, guess, o, &fine_best);
  const Candidate& second = coarse_best.second;
  return {SE2(fine_best.t.x(), fine_best.t.y(), fine_best.theta), fine_best.score,
          coarse_best.ratio, SE2(second.t.x(), second.t.y(), second.theta)};
}

namespace {

// A scan point's pair in the map: the point in the world frame, its offset
// from the nearest map point, that point's normal (null when it has none)
// and the Jacobian row of the point-to-line residual nrm . d.
struct IcpPair {
  Eigen::Vector2d rp;  // the point rotated into the world frame, before translation
  Eigen::Vector2d d;
  const Eigen::Vector2d* normal = nullptr;
  bool found = false;
};

IcpPair Pair(const MatchMap& map, const Eigen::Vector2d& p, double x, double y, double c,
             double s) {
  IcpPair pair;
  pair.rp = Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y());
  const Eigen::Vector2d q = pair.rp + Eigen::Vector2d(x, y);
  const int j = map.Nearest(q);
  if (j < 0) return pair;
  const PointCloud& ref = map.cloud();
  pair.found = true;
  pair.d = q - ref.points[j];
  if (ref.has_normal[j]) pair.normal = &ref.normals[j];
  return pair;
}

Eigen::Vector3d Jacobian(const IcpPair& pair) {
  const Eigen::Vector2d& nrm = *pair.normal;
  return Eigen::Vector3d(nrm.x(), nrm.y(), nrm.dot(Eigen::Vector2d(-pair.rp.y(), pair.rp.x())));
}

// The Huber-weighted normal equations H, g over the pairs within `corr`;
// returns how many pairs went in.
int Linearize(const MatchMap& map, const PointCloud& scan, double x, double y, double th,
              double corr, Eigen::Matrix3d* H, Eigen::Vector3d* g) {
  const double c = std::cos(th), s = std::sin(th);
  *H = Eigen::Matrix3d::Zero();
  *g = Eigen::Vector3d::Zero();
  int used = 0;
  for (size_t i = 0; i < scan.size(); ++i) {
    const IcpPair pair = Pair(map, scan.points[i], x, y, c, s);
    if (!pair.found || !pair.normal) continue;
    if (pair.d.norm() > corr) continue;
    const double r = pair.normal->dot(pair.d);
    const Eigen::Vector3d J = Jacobian(pair);
    const double k = 0.05;  // Huber: far residuals are likely wrong pairs
    const double w = std::abs(r) < k ? 1.0 : k / std::abs(r);
    *H += w * J * J.transpose();
    *g += w * J * r;
    ++used;
  }
  return used;
}

// Solve in H's eigenbasis and leave unobservable directions (a corridor's
// axis) where the guess put them, rather than let noise slide the pose
// along them.
Eigen::Vector3d ObservableStep(const Eigen::Matrix3d& H, const Eigen::Vector3d& g) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(H);
  const Eigen::Vector3d lam = es.eigenvalues();
  const Eigen::Vector3d proj = es.eigenvectors().transpose() * g;
  Eigen::Vector3d step = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k)
    if (lam[k] > 1e-3 * lam[2] && lam[k] > 1e-9) step[k] = -proj[k] / lam[k];
  return es.eigenvectors() * step;
}

// Fitness and the information at out->pose, with a fixed inlier radius.
void MeasureFit(const MatchMap& map, const PointCloud& scan, double x, double y, double th,
                const IcpOptions& o, IcpResult* out) {
  const double c = std::cos(th), s = std::sin(th);
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  double sum_r = 0, sum_r2 = 0;
  int with_normal = 0;
  for (size_t i = 0; i < scan.size(); ++i) {
    const IcpPair pair = Pair(map, scan.points[i], x, y, c, s);
    if (!pair.found) continue;
    if (pair.d.norm() > o.inlier_distance) continue;
    ++out->inliers;
    if (!pair.normal) continue;
    const double r = pair.normal->dot(pair.d);
    const Eigen::Vector3d J = Jacobian(pair);
    H += J * J.transpose();
    sum_r += std::abs(r);
    sum_r2 += r * r;
    ++with_normal;
  }
  out->inlier_fraction = scan.size() ? static_cast<double>(out->inliers) / scan.size() : 0;
  out->mean_residual = with_normal ? sum_r / with_normal : 1e9;
  if (with_normal < 10) {
    out->converged = false;
    return;
  }
  const double sigma2 = std::max(sum_r2 / std::max(1, with_normal - 3), 0.01 * 0.01);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(H);
  Eigen::Vector3d lam = es.eigenvalues();
  // Invert with the weak directions (a corridor's axis) capped at max_sigma.
  const double max_var = o.max_sigma * o.max_sigma;
  Eigen::Vector3d var;
  for (int k = 0; k < 3; ++k)
    var[k] = std::min(max_var, o.covariance_inflation * sigma2 / std::max(lam[k], 1e-12));
  Eigen::Matrix3d cov = es.eigenvectors() * var.asDiagonal() * es.eigenvectors().transpose();
  cov(0, 0) += o.min_sigma_xy * o.min_sigma_xy;
  cov(1, 1) += o.min_sigma_xy * o.min_sigma_xy;
  cov(2, 2) += o.min_sigma_theta * o.min_sigma_theta;
  out->information = cov.inverse();
  out->information = 0.5 * (out->information + out->information.transpose()).eval();
}

}  // namespace

IcpResult IcpMatch(const MatchMap& map, const PointCloud& scan, const SE2& guess,
                   const IcpOptions& o) {
  IcpResult out;
  double x = guess.x(), y = guess.y(), th = guess.theta();
  for (int it = 0; it < o.max_iterations; ++it) {
    // The correspondence radius shrinks over the first half of the iterations.
    const double frac = std::min(1.0, it / (0.5 * o.max_iterations));
    const double corr = o.max_correspondence + frac * (o.min_correspondence - o.max_correspondence);
    Eigen::Matrix3d H;
    Eigen::Vector3d g;
    if (Linearize(map, scan, x, y, th, corr, &H, &g) < 10) break;
    const Eigen::Vector3d delta = ObservableStep(H, g);
    x += delta[0];
    y += delta[1];
    th = NormalizeAngle(th + delta[2]);
    if (frac >= 1.0 && delta.head<2>().norm() < 1e-4 && std::abs(delta[2]) < 1e-4) {
      out.converged = true;
      break;
    }
    if (it + 1 == o.max_iterations) out.converged = true;
  }
  out.pose = SE2(x, y, th);
  MeasureFit(map, scan, x, y, th, o, &out);
  return out;
}

}  // namespace cairn::frontend
