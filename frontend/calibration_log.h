// Calibration pairs from a CARMEN log: the raw odometry between scans
// against the reference (corrected) increments, read by frontend/carmen_log.h.
#pragma once

#include <string>

#include "cairn/calibration/odometry_calibration.h"

namespace cairn {

// Reads a CARMEN log (plain or gzip'd) and fills the trajectory fields and
// the pairs; steps with no ODOM line between two scans stay out of the fit.
// Throws ParseError (FILE:LINE) on a malformed line.
CalibrationData ReadCarmenCalibration(const std::string& path);

}  // namespace cairn
