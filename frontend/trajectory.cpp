#include "cairn/frontend/trajectory.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/text_input.h"
#include "cairn/frontend/carmen_log.h"

namespace cairn::frontend {

void Trajectory::Add(double stamp, const SE2& pose, long index, std::string text) {
  stamps.push_back(stamp);
  poses.push_back(pose);
  scan_index.push_back(index);
  stamp_texts.push_back(std::move(text));
}

namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

Trajectory FromCarmen(const std::string& path) {
  const CarmenLog log = ReadCarmenLog(path);
  Trajectory t;
  for (size_t i = 0; i < log.scans.size(); ++i)
    t.Add(log.scans[i].timestamp, log.scans[i].reference, static_cast<long>(i),
          log.scans[i].timestamp_text);
  return t;
}

Trajectory FromG2o(const std::string& path) {
  const PoseGraph g = ReadGraph(path);
  if (g.dimension() != 2) throw std::runtime_error(path + ": not a 2D graph");
  Trajectory t;
  t.stamps_are_ids = true;
  std::map<int64_t, SE2> sorted;
  // The poses alone: landmarks are not part of the trajectory.
  for (const Vertex& v : g.vertices())
    if (!v.landmark) sorted[v.id] = ToSE2(v.x);
  for (const auto& [id, pose] : sorted) t.Add(static_cast<double>(id), pose);
  return t;
}

Trajectory FromTum(const std::string& path, std::istream& in) {
  Trajectory t;
  TextInput input(in, path);
  std::string line;
  while (input.Next(&line)) {
    const size_t no = input.line();
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream is(line);
    std::string stamp_text;
    double v[7];
    is >> stamp_text;
    for (double& x : v) is >> x;
    std::string extra;
    if (is.fail()) throw ParseError(path, no, "expected 'timestamp x y z qx qy qz qw'");
    if (is >> extra) throw ParseError(path, no, "unexpected field '" + extra + "'");
    char* end = nullptr;
    const double stamp = std::strtod(stamp_text.c_str(), &end);
    if (*end != '\0' || !std::isfinite(stamp))
      throw ParseError(path, no, "bad timestamp '" + stamp_text + "'");
    for (double x : v)
      if (!std::isfinite(x)) throw ParseError(path, no, "non-finite value");
    const double qx = v[3], qy = v[4], qz = v[5], qw = v[6];
    const double n = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (n < 1e-9) throw ParseError(path, no, "zero quaternion");
    const double yaw = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
    t.Add(stamp, SE2(v[0], v[1], yaw), -1, stamp_text);
  }
  return t;
}

}  // namespace

Trajectory ReadTrajectory(const std::string& path) {
  if (EndsWith(path, ".log") || EndsWith(path, ".log.gz") || EndsWith(path, ".gz"))
    return FromCarmen(path);
  if (EndsWith(path, ".g2o")) return FromG2o(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  // Sniff: a CARMEN or g2o file names its lines with tags.
  std::string line;
  TextInput sniff(in, path);
  while (sniff.Next(&line)) {
    std::istringstream is(line);
    std::string tag;
    if (!(is >> tag) || tag[0] == '#') continue;
    if (tag == "FLASER" || tag == "ODOM" || tag == "PARAM" || tag == "ROBOTLASER1")
      return FromCarmen(path);
    if (tag.rfind("VERTEX", 0) == 0 || tag.rfind("EDGE", 0) == 0) return FromG2o(path);
    break;
  }
  in.clear();
  in.seekg(0);
  return FromTum(path, in);
}

void WriteTum(const Trajectory& traj, std::ostream& out) {
  const std::streamsize precision = out.precision(17);
  out << "# timestamp x y z qx qy qz qw\n";
  for (size_t i = 0; i < traj.size(); ++i) {
    const SE2& p = traj.poses[i];
    const double h = 0.5 * p.theta();
    if (!traj.stamp_texts[i].empty())
      out << traj.stamp_texts[i];
    else
      out << traj.stamps[i];
    out << ' ' << p.x() << ' ' << p.y() << " 0 0 0 " << std::sin(h) << ' ' << std::cos(h) << '\n';
  }
  out.precision(precision);
}

void WriteTum(const Trajectory& traj, const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) { WriteTum(traj, out); });
}

std::vector<std::pair<size_t, size_t>> Associate(const Trajectory& est, const Trajectory& ref) {
  std::vector<std::pair<size_t, size_t>> pairs;
  auto known = [](const Trajectory& t) {
    for (long i : t.scan_index)
      if (i < 0) return false;
    return !t.scan_index.empty();
  };
  if (known(est) && known(ref) && !est.stamps_are_ids && !ref.stamps_are_ids) {
    std::map<long, size_t> ref_at;
    for (size_t j = 0; j < ref.size(); ++j) ref_at.emplace(ref.scan_index[j], j);
    for (size_t i = 0; i < est.size(); ++i) {
      auto it = ref_at.find(est.scan_index[i]);
      if (it != ref_at.end()) pairs.emplace_back(i, it->second);
    }
    return pairs;
  }
  if (est.stamps_are_ids || ref.stamps_are_ids) {
    // g2o vertex k pairs with the k-th pose of a timed trajectory, or with
    // vertex k of another graph.
    auto rank_or_id = [](const Trajectory& t, size_t i) {
      return t.stamps_are_ids ? static_cast<long>(std::llround(t.stamps[i])) : static_cast<long>(i);
    };
    std::map<long, size_t> ref_at;
    for (size_t j = 0; j < ref.size(); ++j) ref_at.emplace(rank_or_id(ref, j), j);
    for (size_t i = 0; i < est.size(); ++i) {
      auto it = ref_at.find(rank_or_id(est, i));
      if (it != ref_at.end()) pairs.emplace_back(i, it->second);
    }
    return pairs;
  }
  // Equal stamps (a log that prints times too coarsely) pair in order of
  // appearance, but only when both sides hold the same number of them:
  // otherwise which is which cannot be told, and the group is left out.
  auto key = [](double s) { return std::llround(s * 1e6); };
  std::map<long long, std::vector<size_t>> ref_at, est_at;
  for (size_t j = 0; j < ref.size(); ++j) ref_at[key(ref.stamps[j])].push_back(j);
  for (size_t i = 0; i < est.size(); ++i) est_at[key(est.stamps[i])].push_back(i);
  for (const auto& [k, is] : est_at) {
    auto it = ref_at.find(k);
    if (it == ref_at.end() || it->second.size() != is.size()) continue;
    for (size_t m = 0; m < is.size(); ++m) pairs.emplace_back(is[m], it->second[m]);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& ref, double segment) {
  TrajectoryErrors out;
  const auto pairs = Associate(est, ref);
  out.matched = pairs.size();
  if (pairs.size() < 2) return out;
  // Rigid 2D alignment (Umeyama without scale) of est positions onto ref.
  Eigen::Vector2d me = Eigen::Vector2d::Zero(), mr = Eigen::Vector2d::Zero();
  for (auto [i, j] : pairs) {
    me += est.poses[i].translation();
    mr += ref.poses[j].translation();
  }
  me /= pairs.size();
  mr /= pairs.size();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (auto [i, j] : pairs)
    cov += (ref.poses[j].translation() - mr) * (est.poses[i].translation() - me).transpose();
  Eigen::JacobiSVD<Eigen::Matrix2d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix2d S = Eigen::Matrix2d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(1, 1) = -1;
  const Eigen::Matrix2d R = svd.matrixU() * S * svd.matrixV().transpose();
  const Eigen::Vector2d t = mr - R * me;
  double sum = 0;
  for (auto [i, j] : pairs) sum += (R * est.poses[i].translation() + t - ref.poses[j].translation()).squaredNorm();
  out.ate_rmse = std::sqrt(sum / pairs.size());

  // RPE: from each matched pose, the first later one at least `segment`
  // metres further along the reference path.
  std::vector<double> along(pairs.size(), 0);
  for (size_t k = 1; k < pairs.size(); ++k)
    along[k] = along[k - 1] + (ref.poses[pairs[k].second].translation() -
                               ref.poses[pairs[k - 1].second].translation()).norm();
  double st = 0, sr = 0;
  size_t n = 0, b = 0;
  for (size_t a = 0; a < pairs.size(); ++a) {
    if (b < a) b = a;
    while (b < pairs.size() && along[b] - along[a] < segment) ++b;
    if (b >= pairs.size()) break;
    const SE2 dr = ref.poses[pairs[a].second].Between(ref.poses[pairs[b].second]);
    const SE2 de = est.poses[pairs[a].first].Between(est.poses[pairs[b].first]);
    const SE2 e = dr.Between(de);
    st += e.translation().squaredNorm();
    sr += e.theta() * e.theta();
    ++n;
  }
  if (n) {
    out.rpe_trans_rmse = std::sqrt(st / n);
    out.rpe_rot_rmse_deg = std::sqrt(sr / n) * 180 / M_PI;
  }
  out.rpe_pairs = n;
  return out;
}

}  // namespace cairn::frontend
