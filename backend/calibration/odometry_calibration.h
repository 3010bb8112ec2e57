// Odometry calibration of a planar robot (`cairn calibrate`): the 3x3 matrix
// X with u*_i = X u_i in the least-squares sense, from pairs of raw odometry
// increments u and reference increments u* (scan matching, SLAM). Solved three
// ways that must agree: closed form, one Gauss-Newton step, Ceres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/graph/pose_graph.h"

namespace cairn {

// One increment pair, both (dx, dy, dtheta) in the previous pose's frame.
struct CalibrationPair {
  Eigen::Vector3d u = Eigen::Vector3d::Zero();       // raw odometry
  Eigen::Vector3d u_star = Eigen::Vector3d::Zero();  // reference
  // Of the error u* - X u; identity when the input gives none.
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  size_t line = 0;  // where it came from in its file (0: not from a file)
};

struct CalibrationData {
  std::vector<CalibrationPair> pairs;
  // Some pairs carry their own information matrix (then every pair's residual
  // is whitened and X's covariance is H^-1, not a fitted sigma^2 H^-1).
  bool has_information = false;
  // With a trajectory (CARMEN log, g2o): reference poses 0..n and the raw
  // increment from pose k to k+1, so dead reckoning can be compared. Steps
  // without odometry are zero increments here and are absent from `pairs`.
  std::vector<SE2> reference_poses;
  std::vector<Eigen::Vector3d> raw_increments;
  // Per step: whether any odometry arrived (empty: all did).
  std::vector<bool> step_has_odometry;
  size_t steps_without_odometry = 0;
};

// Refused input: too few pairs, or a direction of u never excited. what()
// names the direction (e.g. "the robot never turned: ...").
class DegenerateCalibration : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CalibrationOptions {
  // A direction of u is called unexcited when the smallest eigenvalue of the
  // diagonally-normalised sum u u^T is below this fraction of the largest.
  // Normalised so that metres against radians do not matter.
  double degeneracy_threshold = 1e-9;
  bool run_ceres = true;
  bool run_gauss_newton = true;
};

struct DeadReckoningError {
  double rms_before = 0, rms_after = 0;      // RMS position error over all poses (m)
  double final_before = 0, final_after = 0;  // position error at the last pose (m)
  size_t poses = 0;
};

struct CalibrationResult {
  Eigen::Matrix3d x = Eigen::Matrix3d::Identity();  // the closed form: the one reported
  Eigen::Matrix3d x_closed_form, x_gauss_newton, x_ceres;
  bool has_gauss_newton = false, has_ceres = false;
  // Largest |entry difference| between the closed form and the other two.
  double max_disagreement = 0;
  // Standard deviation of each entry of X; NaN when it cannot be estimated
  // (exactly three pairs and no information: no degrees of freedom left).
  Eigen::Matrix3d x_std;
  Eigen::Matrix<double, 9, 9> covariance;  // of X's entries, row-major
  bool covariance_from_information = false;
  double sigma2 = 1;  // residual variance when estimated (RSS / (3N - 9))
  // RMS over all components of the unwhitened residual u* - X u, with X the
  // identity and with the estimate; per component (x, y, theta) too.
  double rms_before = 0, rms_after = 0;
  Eigen::Vector3d rms_before_xyt, rms_after_xyt;
  // Whitened sum of squares (e^T Omega e), before and after.
  double chi2_before = 0, chi2_after = 0;
  size_t pairs = 0;
  int gauss_newton_iterations = 0;
  std::string ceres_termination;
  std::optional<DeadReckoningError> dead_reckoning;
};

// Checks that every direction of u is excited; throws DegenerateCalibration.
void CheckExcitation(const std::vector<CalibrationPair>& pairs, double threshold);

// Estimates X three ways; throws DegenerateCalibration before solving when
// the pairs cannot determine X.
CalibrationResult Calibrate(const CalibrationData& data, const CalibrationOptions& options = {});

// Poses from `start` by chaining X u_k (X = identity: raw dead reckoning).
std::vector<SE2> DeadReckon(const SE2& start, const std::vector<Eigen::Vector3d>& increments,
                            const Eigen::Matrix3d& x);
DeadReckoningError CompareDeadReckoning(const CalibrationData& data, const Eigen::Matrix3d& x);

// The text format: per line "ux uy ut usx usy ust" and optionally six more
// numbers, the upper triangle of the 3x3 information matrix row by row; '#'
// starts a comment. Throws ParseError (FILE:LINE) on a bad line.
CalibrationData ReadCalibrationPairs(const std::string& path);
CalibrationData ReadCalibrationPairs(std::istream& in, const std::string& name);
void WriteCalibrationPairs(const CalibrationData& data, std::ostream& out);

// From an optimised graph and the raw graph holding its odometry: u from the
// raw odometry edges i -> i+1, u* = between(x_i, x_{i+1}) of the optimised
// vertices. With `use_edge_information`, each pair takes its edge's
// information. SE2 only; throws std::invalid_argument otherwise.
CalibrationData CalibrationFromGraphs(const PoseGraph& optimised, const PoseGraph& raw,
                                      bool use_edge_information);

// Fills `pairs` from the trajectory fields (reference poses, raw increments).
void PairsFromTrajectory(CalibrationData* data);

}  // namespace cairn
