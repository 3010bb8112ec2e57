#include "cairn/frontend/relations.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "cairn/graph/text_input.h"

namespace cairn::frontend {

std::vector<Relation> ReadRelations(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  TextInput input(in, path);
  std::vector<Relation> out;
  std::string line;
  while (input.Next(&line)) {
    const size_t no = input.line();
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream is(line);
    double v[8];
    for (double& x : v) is >> x;
    if (is.fail()) throw ParseError(path, no, "expected 't1 t2 x y z roll pitch yaw'");
    std::string extra;
    if (is >> extra) throw ParseError(path, no, "unexpected field '" + extra + "'");
    for (double x : v)
      if (!std::isfinite(x)) throw ParseError(path, no, "non-finite value");
    for (int k = 0; k < 2; ++k)
      if (std::abs(v[k]) > kMaxAbsStamp) throw ParseError(path, no, "time beyond 1e12 s");
    for (int k = 2; k < 5; ++k)
      if (std::abs(v[k]) > kMaxAbsCoordinate) throw ParseError(path, no, "coordinate beyond 1e9");
    for (int k = 5; k < 8; ++k)
      if (std::abs(v[k]) > kMaxAbsAngle) throw ParseError(path, no, "angle beyond 1e3 rad");
    Vector6d e;
    e << v[2], v[3], v[4], v[5], v[6], v[7];
    out.push_back({v[0], v[1], SE3::FromEulerVector(e), no});
  }
  return out;
}

namespace {

// Finds the estimate's pose for a relation's end: by scan index, or the
// nearest stamp (in whole microseconds, as trajectories are paired) within
// the window, refused when that stamp is shared by several poses.
class PoseFinder {
 public:
  PoseFinder(const Trajectory& est, RelationKey key, double max_dt)
      : key_(key), window_(std::llround(std::clamp(max_dt, 0.0, 1e12) * 1e6)) {
    for (size_t i = 0; i < est.size(); ++i) {
      const long long k = key == RelationKey::kScanIndex ? est.scan_index[i]
                                                         : std::llround(est.stamps[i] * 1e6);
      if (key == RelationKey::kScanIndex && k < 0) continue;
      auto [it, fresh] = at_.emplace(k, static_cast<long>(i));
      if (!fresh) it->second = -1;  // shared: ambiguous
    }
  }

  // The pose's index in the estimate, or -1.
  long Find(double t) const {
    if (key_ == RelationKey::kScanIndex) {
      if (t != std::floor(t)) return -1;
      auto it = at_.find(static_cast<long long>(t));
      return it == at_.end() ? -1 : it->second;
    }
    const long long k = std::llround(t * 1e6);
    auto hi = at_.lower_bound(k);
    auto best = at_.end();
    if (hi != at_.end()) best = hi;
    if (hi != at_.begin()) {
      auto lo = std::prev(hi);
      if (best == at_.end() || k - lo->first <= best->first - k) best = lo;
    }
    if (best == at_.end() || std::llabs(best->first - k) > window_) return -1;
    return best->second;
  }

 private:
  RelationKey key_;
  long long window_;
  std::map<long long, long> at_;
};

bool Planar(const SE3& p) { return IsPlanar(p); }

}  // namespace

RelationErrors EvaluateRelations(const Trajectory& est, const std::vector<Relation>& relations,
                                 RelationKey key, double max_dt) {
  RelationErrors out;
  if (key == RelationKey::kScanIndex && est.scan_index.size() != est.size())
    throw std::invalid_argument("the estimate has no scan indices");
  const PoseFinder finder(est, key, max_dt);
  out.dimension = est.dimension;
  std::vector<double> trans, rot, trans_sq, rot_sq;
  for (const Relation& r : relations) {
    const long i = finder.Find(r.t1), j = finder.Find(r.t2);
    if (i < 0 || j < 0) {
      if (!out.unpaired) out.first_unpaired_line = r.line;
      ++out.unpaired;
      continue;
    }
    if (!Planar(r.delta)) out.dimension = 3;
    const SE3 d_est = est.poses3d[static_cast<size_t>(i)].Between(est.poses3d[static_cast<size_t>(j)]);
    const SE3 e = r.delta.Between(d_est);
    const double t = e.translation().norm();
    const double a = QuaternionLog(e.rotation()).norm() * 180 / M_PI;
    trans.push_back(t);
    rot.push_back(a);
    trans_sq.push_back(t * t);
    rot_sq.push_back(a * a);
  }
  out.used = trans.size();
  out.trans = Summarize(trans);
  out.rot_deg = Summarize(rot);
  out.trans_sq = Summarize(trans_sq);
  out.rot_sq_deg2 = Summarize(rot_sq);
  return out;
}

}  // namespace cairn::frontend
