// A stop-gap CARMEN reader for `cairn calibrate`: only the corrected scan
// poses and the raw odometry between scans. Self-contained on purpose, to be
// replaced by the shared CARMEN reader (frontend/carmen_log.h) once it lands.
#pragma once

#include <string>

#include "backend/odometry_calibration.h"

namespace cairn {

// Reads a CARMEN log (plain or gzip'd). Each FLASER line gives a reference
// pose; the raw increment from scan k-1 to scan k is the motion from scan
// k-1's corrected pose to the last ODOM pose before scan k (the log restarts
// the ODOM chain at every corrected pose). Fills the trajectory fields and
// the pairs. Throws ParseError (FILE:LINE) on a malformed FLASER/ODOM line.
CalibrationData ReadCarmenCalibration(const std::string& path);

}  // namespace cairn
