#include "cairn/frontend/calibration_log.h"

#include "cairn/frontend/carmen_log.h"

namespace cairn {

CalibrationData ReadCarmenCalibration(const std::string& path) {
  const frontend::CarmenLog log = frontend::ReadCarmenLog(path);
  CalibrationData data;
  for (size_t k = 0; k < log.scans.size(); ++k) {
    const frontend::LaserScan& scan = log.scans[k];
    if (k > 0) {
      data.raw_increments.push_back(scan.odometry_measured ? scan.odometry_increment.ToVector()
                                                           : Eigen::Vector3d::Zero());
      data.step_has_odometry.push_back(scan.odometry_measured);
    }
    data.reference_poses.push_back(scan.reference);
  }
  PairsFromTrajectory(&data);
  return data;
}

}  // namespace cairn
