// Reading CARMEN laser logs (plain or gzip'd): laser scans, the raw odometry
// between them, and the reference poses that corrected logs carry. The
// front-end sees only ranges and raw odometry; reference poses are for
// evaluation alone.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/graph/text_input.h"

namespace cairn::frontend {

struct LaserScan {
  double timestamp = 0;
  std::string timestamp_text;  // as the log writes it, for TUM output
  double angle_min = 0;        // bearing of the first beam, robot frame
  double angle_increment = 0;
  std::vector<float> ranges;
  // Raw odometry from the previous scan's pose to this one (identity for the
  // first scan of the log).
  SE2 odometry_increment;
  // Whether any ODOM line came between the previous scan and this one (if
  // not, the increment above is the identity by assumption, not measured).
  bool odometry_measured = false;
  // The pose the log carries on the scan line (a reference trajectory in the
  // corrected logs).
  SE2 reference;
  SE2 laser_offset;  // laser in the robot frame (ROBOTLASER1 only)
  // The laser's maximum range as the log declares it (ROBOTLASER1's field,
  // PARAM robot_front_laser_max for FLASER); 0 when it does not say.
  double max_range = 0;
  size_t line = 0;
};

// The front laser as the log's PARAM lines describe it (CARMEN's laser and
// robot modules), applied to the FLASER lines that follow them; NaN (or
// false) where the log says nothing. Without a field of view, 180 degrees.
struct FrontLaserParams {
  double fov_deg = std::nan("");         // laser_front_laser_fov (up to 2 pi: radians)
  double resolution_deg = std::nan("");  // laser_front_laser_resolution
  double max_range = std::nan("");       // robot_front_laser_max, metres
  bool flipped = false;                  // laser_front_laser_flipped: beams right to left
};

struct CarmenLog {
  std::string path;
  std::vector<LaserScan> scans;
  // The largest reading in the log: by convention it means "no return".
  double max_reading = 0;
  // The largest maximum range the log declares (LaserScan::max_range), 0
  // when it declares none.
  double declared_max_range = 0;
  FrontLaserParams front_laser;  // as the last PARAM lines left it
};

// Reads FLASER, ROBOTLASER1, ODOM and PARAM lines; other lines are ignored.
// A FLASER line's beams span the field of view the PARAM lines give (its
// resolution when the beam count fits it), centred ahead; ROBOTLASER1 lines
// carry their own start angle, resolution and maximum range.
// Throws cairn::ParseError ("FILE:LINE: message") on a malformed line and
// std::runtime_error when the file cannot be read. Poses must be finite,
// within kMaxAbsCoordinate and kMaxAbsAngle; a line longer than
// max_line_bytes is an error (text_input.h).
CarmenLog ReadCarmenLog(const std::string& path, size_t max_line_bytes = kDefaultMaxLineBytes);

}  // namespace cairn::frontend
