#include "cairn/frontend/trajectory.h"

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
  poses3d.push_back(Lift(pose));
  scan_index.push_back(index);
  stamp_texts.push_back(std::move(text));
}

void Trajectory::Add(double stamp, const SE3& pose, long index, std::string text) {
  Add(stamp, PlanarView(pose), index, std::move(text));
  poses3d.back() = pose;
  if (!IsPlanar(pose)) dimension = 3;
}

bool IsPlanar(const SE3& pose) {
  const Eigen::Quaterniond& q = pose.rotation();
  return std::abs(pose.translation().z()) <= kPlanarTolerance && std::abs(q.x()) <= kPlanarTolerance &&
         std::abs(q.y()) <= kPlanarTolerance;
}

namespace {

double Yaw(const Eigen::Quaterniond& q) {
  return std::atan2(2 * (q.w() * q.z() + q.x() * q.y()), 1 - 2 * (q.y() * q.y() + q.z() * q.z()));
}

}  // namespace

SE2 PlanarView(const SE3& pose) {
  return SE2(pose.translation().x(), pose.translation().y(), Yaw(pose.rotation()));
}

SE3 Lift(const SE2& pose) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(pose.theta(), Eigen::Vector3d::UnitZ())),
             Eigen::Vector3d(pose.x(), pose.y(), 0));
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
  Trajectory t;
  t.stamps_are_ids = true;
  std::map<int64_t, const Vertex*> sorted;
  // The poses alone: landmarks are not part of the trajectory.
  for (const Vertex& v : g.vertices())
    if (!v.landmark) sorted[v.id] = &v;
  for (const auto& [id, v] : sorted) {
    if (g.dimension() == 2)
      t.Add(static_cast<double>(id), ToSE2(v->x));
    else
      t.Add(static_cast<double>(id), ToSE3(v->x));
  }
  // A 3D graph is evaluated in 3D even when it happens to lie in the plane.
  if (g.dimension() == 3) t.dimension = 3;
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
    // Pairing compares stamps in whole microseconds; a stamp in nanoseconds
    // would overflow that, and pair nothing or the wrong poses.
    if (std::abs(stamp) > kMaxAbsStamp)
      throw ParseError(path, no, "timestamp '" + stamp_text + "' beyond 1e12 s (TUM stamps are seconds)");
    for (double x : v)
      if (!std::isfinite(x)) throw ParseError(path, no, "non-finite value");
    for (int k = 0; k < 3; ++k)
      if (std::abs(v[k]) > kMaxAbsCoordinate) {
        std::ostringstream msg;
        msg << "coordinate " << v[k] << " beyond " << kMaxAbsCoordinate << " in magnitude";
        throw ParseError(path, no, msg.str());
      }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    const double n = q.norm();
    if (n < 1e-9) throw ParseError(path, no, "zero quaternion");
    // As the g2o reader: rounding in the file is corrected, a quaternion far
    // from unit length is a wrong column, not a rotation.
    if (std::abs(n - 1) > 1e-2)
      throw ParseError(path, no, "quaternion is far from unit length (norm " + std::to_string(n) + ")");
    t.Add(stamp, SE3(q, Eigen::Vector3d(v[0], v[1], v[2])), -1, stamp_text);
    // The planar view from the quaternion as written, not as normalised: a
    // planar file evaluates bit for bit as it did before 3D was read.
    t.poses.back() = SE2(v[0], v[1], Yaw(q));
  }
  return t;
}

// cairn map's PREFIX_keyframes.csv (keyframe,scan,timestamp,x,y,theta) or
// --scan-poses file (scan,timestamp,x,y,theta): planar poses that know
// their scan index.
Trajectory FromCsv(const std::string& path, std::istream& in) {
  TextInput input(in, path);
  std::string line;
  input.Next(&line);
  const bool with_keyframe = line.rfind("keyframe,", 0) == 0;
  const size_t fields = with_keyframe ? 6 : 5;
  Trajectory t;
  while (input.Next(&line)) {
    const size_t no = input.line();
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::vector<std::string> f;
    std::istringstream is(line);
    for (std::string cell; std::getline(is, cell, ',');) f.push_back(cell);
    if (f.size() != fields)
      throw ParseError(path, no, "expected " + std::to_string(fields) + " comma-separated fields");
    double v[5];  // scan, timestamp, x, y, theta
    for (size_t k = 0; k < 5; ++k) {
      char* end = nullptr;
      const std::string& cell = f[k + (with_keyframe ? 1 : 0)];
      v[k] = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || !std::isfinite(v[k]))
        throw ParseError(path, no, "bad number '" + cell + "'");
    }
    if (v[0] < 0 || v[0] != std::floor(v[0])) throw ParseError(path, no, "bad scan index");
    if (std::abs(v[1]) > kMaxAbsStamp) throw ParseError(path, no, "timestamp beyond 1e12 s");
    if (std::abs(v[2]) > kMaxAbsCoordinate || std::abs(v[3]) > kMaxAbsCoordinate ||
        std::abs(v[4]) > kMaxAbsAngle)
      throw ParseError(path, no, "coordinate or heading out of range");
    t.Add(v[1], SE2(v[2], v[3], v[4]), static_cast<long>(v[0]),
          f[with_keyframe ? 2 : 1]);
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
    if (tag.rfind("keyframe,scan,", 0) == 0 || tag.rfind("scan,timestamp,", 0) == 0) {
      in.clear();
      in.seekg(0);
      return FromCsv(path, in);
    }
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
    if (!traj.stamp_texts[i].empty())
      out << traj.stamp_texts[i];
    else
      out << traj.stamps[i];
    if (traj.dimension == 2) {
      // Written from the planar view, so that z and the tilt are exactly 0.
      const SE2& p = traj.poses[i];
      const double h = 0.5 * p.theta();
      out << ' ' << p.x() << ' ' << p.y() << " 0 0 0 " << std::sin(h) << ' ' << std::cos(h) << '\n';
    } else {
      const Eigen::Vector3d& t = traj.poses3d[i].translation();
      const Eigen::Quaterniond& q = traj.poses3d[i].rotation();
      out << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' '
          << q.z() << ' ' << q.w() << '\n';
    }
  }
  out.precision(precision);
}

void WriteTum(const Trajectory& traj, const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) { WriteTum(traj, out); });
}

}  // namespace cairn::frontend
