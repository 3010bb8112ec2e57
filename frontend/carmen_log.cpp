#include "cairn/frontend/carmen_log.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/text_input.h"

namespace cairn::frontend {
namespace {

// Fields are separated by any run of blanks.
std::vector<std::string> Tokens(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream is(line);
  std::string t;
  while (is >> t) out.push_back(t);
  return out;
}

class LineParser {
 public:
  LineParser(const std::string& file, size_t line, std::vector<std::string> tokens)
      : file_(file), line_(line), t_(std::move(tokens)) {}

  size_t size() const { return t_.size(); }
  const std::string& Text(size_t i) const {
    Need(i + 1);
    return t_[i];
  }
  void Need(size_t n) const {
    if (t_.size() < n)
      Fail(t_[0] + " line has " + std::to_string(t_.size()) + " fields, needs at least " +
           std::to_string(n));
  }
  double Double(size_t i, const char* what) const {
    Need(i + 1);
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(t_[i].c_str(), &end);
    if (*end != '\0' || errno == ERANGE || !std::isfinite(v))
      Fail(std::string("bad ") + what + " '" + t_[i] + "'");
    return v;
  }
  // Fields i, i+1, i+2 as a pose (x, y, theta) within the sane ranges: a
  // corrupt field is this line's error, not a failure far off in the mapper.
  SE2 Pose(size_t i) const {
    const double x = Double(i, "x"), y = Double(i + 1, "y"), theta = Double(i + 2, "theta");
    if (std::fabs(x) > kMaxAbsCoordinate || std::fabs(y) > kMaxAbsCoordinate)
      Fail("pose (" + t_[i] + ", " + t_[i + 1] + ") is out of range (coordinates at most " +
           Shorten(kMaxAbsCoordinate) + " in magnitude)");
    if (std::fabs(theta) > kMaxAbsAngle)
      Fail("theta " + t_[i + 2] + " is out of range (at most " + Shorten(kMaxAbsAngle) +
           " rad in magnitude)");
    return SE2(x, y, theta);
  }
  int Count(size_t i, const char* what, int max) const {
    const double v = Double(i, what);
    if (v < 0 || v > max || v != std::floor(v))
      Fail(std::string("bad ") + what + " '" + t_[i] + "'");
    return static_cast<int>(v);
  }
  [[noreturn]] void Fail(const std::string& message) const {
    throw ParseError(file_, line_, message);
  }

 private:
  static std::string Shorten(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
  }

  const std::string& file_;
  size_t line_;
  std::vector<std::string> t_;
};

// gzopen reads plain files transparently, so one path serves both; the
// lines themselves come through the readers' common TextInput.
class LineReader {
 public:
  LineReader(const std::string& path, size_t max_line_bytes)
      : file_(gzopen(path.c_str(), "rb")),
        input_([this](char* buf, size_t n) { return Read(buf, n); }, path, max_line_bytes) {
    if (!file_) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
    gzbuffer(file_, 1 << 17);
  }
  ~LineReader() {
    if (file_) gzclose(file_);
  }
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  bool Next(std::string* line) {
    if (!input_.Next(line)) return false;
    if (line->find('\0') != std::string::npos)
      throw ParseError(input_.name(), input_.line(), "binary data (a NUL byte), not a CARMEN log");
    return true;
  }

 private:
  size_t Read(char* buf, size_t n) {
    const int got = gzread(file_, buf, static_cast<unsigned>(n));
    if (got < 0) {
      int err = 0;
      throw std::runtime_error(std::string("read error: ") + gzerror(file_, &err));
    }
    return static_cast<size_t>(got);
  }

  gzFile file_;
  TextInput input_;
};

// CARMEN writes the field of view in degrees (180), older logs in radians
// (csail's 3.14159): no laser spans less than 2 pi degrees, so a value up to
// 2 pi is radians.
double FovRadians(double value) { return value <= 2 * M_PI + 1e-9 ? value : value * M_PI / 180; }

// The beams' bearings of an n-beam FLASER scan. The declared resolution
// when n beams at it span the field of view (as n - 1 or n steps); else the
// field of view split by the count, an odd count closed at both ends
// (181 beams over 180 degrees), an even one open (180 over 180).
void FlaserGeometry(const FrontLaserParams& params, int n, LaserScan* scan) {
  const double fov = std::isnan(params.fov_deg) ? M_PI : FovRadians(params.fov_deg);
  const double res = params.resolution_deg * M_PI / 180;
  double steps = (n % 2) == 1 ? n - 1 : n;
  double increment = fov / steps;
  for (const int s : {n - 1, n})
    if (!std::isnan(res) && std::abs(s * res - fov) < 0.5 * res) {
      steps = s;
      increment = res;
      break;
    }
  // Centred on the span the beams cover, which a rounded field of view
  // (3.14159) only approximates.
  scan->angle_increment = increment;
  scan->angle_min = -steps * increment / 2;
  if (!std::isnan(params.max_range)) scan->max_range = params.max_range;
}

// FLASER n r1 .. rn x y theta odom_x odom_y odom_theta timestamp ...: the
// ranges and the corrected pose; returns the timestamp's field.
size_t ParseFlaser(LineParser& p, const FrontLaserParams& params, LaserScan* scan) {
  const int n = p.Count(1, "number of readings", 100000);
  if (n < 2) p.Fail("a scan needs at least 2 readings");
  p.Need(2 + n + 9);
  scan->ranges.resize(n);
  for (int i = 0; i < n; ++i) scan->ranges[i] = static_cast<float>(p.Double(2 + i, "range"));
  if (params.flipped) std::reverse(scan->ranges.begin(), scan->ranges.end());
  FlaserGeometry(params, n, scan);
  size_t k = 2 + n;
  scan->reference = p.Pose(k);
  return k + 6;
}

// PARAM NAME VALUE ...: the front laser's geometry; other parameters say
// nothing the front-end uses. A geometry value that is not a sane number is
// this line's error.
void ParseParam(const LineParser& p, FrontLaserParams* params) {
  p.Need(3);
  const std::string& name = p.Text(1);
  auto positive = [&](double max) {
    const double v = p.Double(2, name.c_str());
    if (!(v > 0) || v > max) p.Fail("bad " + name + " '" + p.Text(2) + "'");
    return v;
  };
  if (name == "laser_front_laser_fov") params->fov_deg = positive(360);
  if (name == "laser_front_laser_resolution") params->resolution_deg = positive(360);
  if (name == "robot_front_laser_max") params->max_range = positive(kMaxAbsCoordinate);
  if (name == "laser_front_laser_flipped") params->flipped = p.Double(2, name.c_str()) != 0;
}

// ROBOTLASER1 with its own angles, remissions, and the laser's pose beside
// the robot's; returns the timestamp's field.
size_t ParseRobotLaser(LineParser& p, LaserScan* scan) {
  p.Need(10);
  const double start = p.Double(2, "start angle");
  p.Double(3, "field of view");
  const double res = p.Double(4, "angular resolution");
  const double max_range = p.Double(5, "maximum range");
  if (max_range > 0) scan->max_range = max_range;
  const int n = p.Count(8, "number of readings", 100000);
  if (n < 2) p.Fail("a scan needs at least 2 readings");
  p.Need(9 + n + 1);
  scan->ranges.resize(n);
  for (int i = 0; i < n; ++i) scan->ranges[i] = static_cast<float>(p.Double(9 + i, "range"));
  size_t k = 9 + n;
  const int nr = p.Count(k, "number of remissions", 100000);
  k += 1 + nr;
  p.Need(k + 14);
  const SE2 laser = p.Pose(k);
  scan->reference = p.Pose(k + 3);
  scan->laser_offset = scan->reference.Between(laser);
  scan->angle_min = start;
  scan->angle_increment = res;
  return k + 11;
}

// The ODOM chain restarts at each scan's pose; the last ODOM before a scan
// gives the raw motion since the previous one.
class OdometryChain {
 public:
  void Odom(const SE2& pose) {
    last_odom_ = pose;
    have_odom_ = true;
    odom_since_scan_ = true;
  }
  void Scan(LaserScan* scan) {
    if (have_prev_scan_ && have_odom_) scan->odometry_increment = prev_scan_pose_.Between(last_odom_);
    scan->odometry_measured = have_prev_scan_ && odom_since_scan_;
    odom_since_scan_ = false;
    prev_scan_pose_ = scan->reference;
    // Until an ODOM line follows, the robot has not moved since this scan.
    last_odom_ = scan->reference;
    have_prev_scan_ = true;
    have_odom_ = true;
  }

 private:
  bool have_prev_scan_ = false, have_odom_ = false, odom_since_scan_ = false;
  SE2 prev_scan_pose_, last_odom_;
};

}  // namespace

CarmenLog ReadCarmenLog(const std::string& path, size_t max_line_bytes) {
  CarmenLog log;
  log.path = path;
  LineReader reader(path, max_line_bytes);
  std::string text;
  size_t line_no = 0;
  OdometryChain odometry;
  while (reader.Next(&text)) {
    ++line_no;
    const size_t first = text.find_first_not_of(" \t");
    if (first == std::string::npos || text[first] == '#') continue;
    const size_t end = text.find_first_of(" \t", first);
    const std::string tag = text.substr(first, end == std::string::npos ? end : end - first);
    if (tag != "FLASER" && tag != "ROBOTLASER1" && tag != "ODOM" && tag != "PARAM") continue;
    LineParser p(path, line_no, Tokens(text));
    if (tag == "PARAM") {
      ParseParam(p, &log.front_laser);
      continue;
    }
    if (tag == "ODOM") {
      p.Need(10);
      const SE2 pose = p.Pose(1);
      p.Double(7, "timestamp");
      odometry.Odom(pose);
      continue;
    }
    LaserScan scan;
    scan.line = line_no;
    const size_t k =
        tag == "FLASER" ? ParseFlaser(p, log.front_laser, &scan) : ParseRobotLaser(p, &scan);
    p.Need(k + 1);
    scan.timestamp = p.Double(k, "timestamp");
    scan.timestamp_text = p.Text(k);
    for (float r : scan.ranges) {
      if (r < 0) p.Fail("negative range");
      log.max_reading = std::max(log.max_reading, static_cast<double>(r));
    }
    log.declared_max_range = std::max(log.declared_max_range, scan.max_range);
    odometry.Scan(&scan);
    log.scans.push_back(std::move(scan));
  }
  return log;
}

}  // namespace cairn::frontend
