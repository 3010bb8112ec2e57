#include "cairn/calibration/odometry_calibration.h"

#include <ceres/problem.h>
#include <ceres/solver.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <limits>
#include <map>
#include <sstream>

#include "cairn/solvers/gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/text_input.h"
#include "cairn/factors/odometry_calibration.h"

namespace cairn {
namespace {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix39d = Eigen::Matrix<double, 3, 9>;

const char* const kComponent[3] = {"dx", "dy", "dtheta"};
const char* const kColumn[3] = {"x", "y", "theta"};

// d(X u)/d vec(X) with vec row-major: the residual's Jacobian up to sign.
Matrix39d DesignMatrix(const Eigen::Vector3d& u) {
  Matrix39d a = Matrix39d::Zero();
  for (int k = 0; k < 3; ++k) a.block<1, 3>(k, 3 * k) = u.transpose();
  return a;
}

Eigen::Matrix3d FromRowMajor(const double* x) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = x[i];
  return m;
}

std::string Fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// Why a single component is never excited, in the user's terms.
std::string UnexcitedComponent(int j) {
  switch (j) {
    case 0:
      return "no forward motion (dx is always 0): the x column of X cannot be estimated";
    case 1:
      return "no sideways motion (dy is always 0): the y column of X cannot be estimated";
    default:
      return "the robot never turned (dtheta is always 0): the theta column of X cannot be "
             "estimated";
  }
}

}  // namespace

void CheckExcitation(const std::vector<CalibrationPair>& pairs, double threshold) {
  if (pairs.size() < 3)
    throw DegenerateCalibration("need at least 3 pairs to estimate the 9 entries of X, got " +
                                std::to_string(pairs.size()));
  // X's rows decouple in the unweighted problem and each sees the same
  // sum u u^T; any positive definite weighting keeps its null space, so this
  // one matrix decides identifiability whatever the information matrices.
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const CalibrationPair& p : pairs) m += p.u * p.u.transpose();
  const Eigen::Vector3d d = m.diagonal();
  const double d_max = d.maxCoeff();
  if (!(d_max > 0)) throw DegenerateCalibration("every odometry increment is zero: X cannot be estimated");
  // Name every unexcited component: a robot that never turned has usually
  // not moved sideways either.
  std::string unexcited;
  for (int j = 2; j >= 0; --j)
    if (d[j] <= threshold * d_max) unexcited += (unexcited.empty() ? "" : "; ") + UnexcitedComponent(j);
  if (!unexcited.empty()) throw DegenerateCalibration(unexcited);
  // Combinations: u confined to a plane, e.g. dtheta proportional to dx (one
  // constant curvature). Normalised by the diagonal so units do not matter.
  const Eigen::Vector3d s = d.cwiseSqrt().cwiseInverse();
  const Eigen::Matrix3d c = s.asDiagonal() * m * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
  if (lambda[0] > threshold * lambda[2]) return;
  Eigen::Vector3d v = s.asDiagonal() * eig.eigenvectors().col(0);  // v^T u ~ 0 for every pair
  v /= v.cwiseAbs().maxCoeff();
  std::string combination;
  for (int j = 0; j < 3; ++j) {
    if (std::abs(v[j]) < 1e-12) continue;
    if (!combination.empty()) combination += v[j] < 0 ? " - " : " + ";
    else if (v[j] < 0) combination += "-";
    combination += Fmt(std::abs(v[j])) + " " + kComponent[j];
  }
  throw DegenerateCalibration(
      "the increments never leave a plane: " + combination +
      " is always 0 (e.g. the robot only drove one arc of constant curvature), so X's columns "
      "cannot be told apart along that combination");
}

namespace {

// The closed form: the normal equations H vec(X) = g, by Cholesky. Fills
// x_closed_form and x, and leaves the factorisation of H in `llt`.
void SolveClosedForm(const std::vector<CalibrationPair>& pairs, Eigen::LLT<Matrix9d>* llt,
                     CalibrationResult* result) {
  Matrix9d h = Matrix9d::Zero();
  Vector9d g = Vector9d::Zero();
  for (const CalibrationPair& p : pairs) {
    const Matrix39d a = DesignMatrix(p.u);
    h += a.transpose() * p.information * a;
    g += a.transpose() * p.information * p.u_star;
  }
  llt->compute(h);
  if (llt->info() != Eigen::Success)
    throw DegenerateCalibration("the normal matrix of X is not positive definite");
  const Vector9d x = llt->solve(g);
  result->x_closed_form = FromRowMajor(x.data());
  result->x = result->x_closed_form;
}

// Residuals before (X = I) and after; returns the residual sum of squares
// after.
double FillResiduals(const std::vector<CalibrationPair>& pairs, CalibrationResult* result) {
  double rss_before = 0, rss_after = 0;
  Eigen::Vector3d sq_before = Eigen::Vector3d::Zero(), sq_after = Eigen::Vector3d::Zero();
  for (const CalibrationPair& p : pairs) {
    const Eigen::Vector3d e0 = p.u_star - p.u, e1 = p.u_star - result->x * p.u;
    sq_before += e0.cwiseAbs2();
    sq_after += e1.cwiseAbs2();
    result->chi2_before += e0.dot(p.information * e0);
    result->chi2_after += e1.dot(p.information * e1);
  }
  rss_before = sq_before.sum();
  rss_after = sq_after.sum();
  const double n = static_cast<double>(pairs.size());
  result->rms_before = std::sqrt(rss_before / (3 * n));
  result->rms_after = std::sqrt(rss_after / (3 * n));
  result->rms_before_xyt = (sq_before / n).cwiseSqrt();
  result->rms_after_xyt = (sq_after / n).cwiseSqrt();
  return rss_after;
}

// Uncertainty: with information matrices the residuals are whitened and
// H^-1 is the covariance; without, the noise level is fitted from the
// residuals themselves (3N equations, 9 unknowns).
void FillCovariance(const CalibrationData& data, const Eigen::LLT<Matrix9d>& llt, double rss_after,
                    CalibrationResult* result) {
  const Matrix9d h_inv = llt.solve(Matrix9d::Identity());
  if (data.has_information) {
    result->covariance_from_information = true;
    result->sigma2 = 1;
    result->covariance = h_inv;
  } else {
    const double dof = 3 * static_cast<double>(data.pairs.size()) - 9;
    result->sigma2 = dof > 0 ? rss_after / dof : std::numeric_limits<double>::quiet_NaN();
    result->covariance = result->sigma2 * h_inv;
  }
  for (int i = 0; i < 9; ++i) result->x_std(i / 3, i % 3) = std::sqrt(result->covariance(i, i));
}

// Hand-written Gauss-Newton from X = I: one iteration, as the problem is linear.
void SolveByGaussNewton(const std::vector<CalibrationPair>& pairs, CalibrationResult* result) {
  double xg[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  GaussNewtonProblem problem;
  problem.AddParameterBlock(xg, 9);
  for (const CalibrationPair& p : pairs)
    problem.AddResidualBlock(factors::OdometryCalibrationFactor::Create(p.u, p.u_star, p.information),
                             nullptr, {xg});
  GaussNewtonOptions o;
  o.max_iterations = 1;
  o.threads = 1;
  o.verbose = false;
  o.gradient_tolerance = 0;  // always take the step, even from a near-perfect start
  const SolveResult r = problem.Solve(o);
  result->gauss_newton_iterations = r.iterations;
  result->x_gauss_newton = FromRowMajor(xg);
  result->has_gauss_newton = true;
  result->max_disagreement = std::max(
      result->max_disagreement, (result->x_gauss_newton - result->x).cwiseAbs().maxCoeff());
}

// Ceres on the same autodiff factor. Levenberg-Marquardt with a huge first
// radius is Gauss-Newton in effect; tolerances at round-off so that the
// three answers can be compared to 1e-9.
void SolveByCeres(const std::vector<CalibrationPair>& pairs, CalibrationResult* result) {
  double xc[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  ceres::Problem problem;
  for (const CalibrationPair& p : pairs)
    problem.AddResidualBlock(factors::OdometryCalibrationFactor::Create(p.u, p.u_star, p.information),
                             nullptr, xc);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.initial_trust_region_radius = 1e16;
  so.max_num_iterations = 50;
  so.function_tolerance = 1e-16;
  so.gradient_tolerance = 1e-16;
  so.parameter_tolerance = 1e-16;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  result->ceres_termination = ceres::TerminationTypeToString(summary.termination_type);
  result->x_ceres = FromRowMajor(xc);
  result->has_ceres = true;
  result->max_disagreement =
      std::max(result->max_disagreement, (result->x_ceres - result->x).cwiseAbs().maxCoeff());
}

}  // namespace

CalibrationResult Calibrate(const CalibrationData& data, const CalibrationOptions& options) {
  const std::vector<CalibrationPair>& pairs = data.pairs;
  CheckExcitation(pairs, options.degeneracy_threshold);
  CalibrationResult result;
  result.pairs = pairs.size();
  Eigen::LLT<Matrix9d> llt;
  SolveClosedForm(pairs, &llt, &result);
  const double rss_after = FillResiduals(pairs, &result);
  FillCovariance(data, llt, rss_after, &result);
  if (options.run_gauss_newton) SolveByGaussNewton(pairs, &result);
  if (options.run_ceres) SolveByCeres(pairs, &result);
  if (!data.reference_poses.empty() &&
      data.reference_poses.size() == data.raw_increments.size() + 1)
    result.dead_reckoning = CompareDeadReckoning(data, result.x);
  return result;
}

std::vector<SE2> DeadReckon(const SE2& start, const std::vector<Eigen::Vector3d>& increments,
                            const Eigen::Matrix3d& x) {
  std::vector<SE2> poses{start};
  poses.reserve(increments.size() + 1);
  // X u's third entry is a heading increment; SE2 wraps the sum.
  for (const Eigen::Vector3d& u : increments)
    poses.push_back(poses.back() * SE2::FromVector(x * u));
  return poses;
}

DeadReckoningError CompareDeadReckoning(const CalibrationData& data, const Eigen::Matrix3d& x) {
  const std::vector<SE2>& ref = data.reference_poses;
  DeadReckoningError out;
  out.poses = ref.size();
  if (ref.empty()) return out;
  auto errors = [&](const Eigen::Matrix3d& m, double* rms, double* last) {
    const std::vector<SE2> dr = DeadReckon(ref.front(), data.raw_increments, m);
    double sum = 0;
    for (size_t k = 0; k < ref.size(); ++k)
      sum += (dr[k].translation() - ref[k].translation()).squaredNorm();
    *rms = std::sqrt(sum / ref.size());
    *last = (dr.back().translation() - ref.back().translation()).norm();
  };
  errors(Eigen::Matrix3d::Identity(), &out.rms_before, &out.final_before);
  errors(x, &out.rms_after, &out.final_after);
  return out;
}

void PairsFromTrajectory(CalibrationData* data) {
  data->pairs.clear();
  data->steps_without_odometry = 0;
  for (size_t k = 0; k < data->raw_increments.size(); ++k) {
    // A step with no odometry message is no evidence about X; dead reckoning
    // still sees it, as zero motion.
    if (k < data->step_has_odometry.size() && !data->step_has_odometry[k]) {
      ++data->steps_without_odometry;
      continue;
    }
    CalibrationPair p;
    p.u = data->raw_increments[k];
    p.u_star = data->reference_poses[k].Between(data->reference_poses[k + 1]).ToVector();
    data->pairs.push_back(p);
  }
}

namespace {

bool ParseDouble(const std::string& token, double* out) {
  char* end = nullptr;
  *out = std::strtod(token.c_str(), &end);
  return end && *end == '\0' && end != token.c_str() && std::isfinite(*out);
}

}  // namespace

CalibrationData ReadCalibrationPairs(std::istream& in, const std::string& name) {
  CalibrationData data;
  TextInput input(in, name);
  std::string line;
  size_t line_no = 0, first_with_info = 0, first_without_info = 0;
  while (input.Next(&line)) {
    line_no = input.line();
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream ss(line);
    std::vector<std::string> tokens;
    for (std::string t; ss >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    if (tokens.size() != 6 && tokens.size() != 12)
      throw ParseError(name, line_no,
                       "expected 6 numbers (ux uy utheta ustar_x ustar_y ustar_theta), or 12 with "
                       "the information matrix's upper triangle; got " +
                           std::to_string(tokens.size()));
    double v[12];
    for (size_t i = 0; i < tokens.size(); ++i)
      if (!ParseDouble(tokens[i], &v[i]))
        throw ParseError(name, line_no, "not a finite number: '" + tokens[i] + "'");
    CalibrationPair p;
    p.line = line_no;
    p.u << v[0], v[1], v[2];
    p.u_star << v[3], v[4], v[5];
    if (tokens.size() == 12) {
      p.information << v[6], v[7], v[8], v[7], v[9], v[10], v[8], v[10], v[11];
      if (!IsSymmetricPositiveDefinite(p.information))
        throw ParseError(name, line_no, "the information matrix is not positive definite");
      if (!first_with_info) first_with_info = line_no;
    } else if (!first_without_info) {
      first_without_info = line_no;
    }
    // Identity beside real information matrices would be an arbitrary scale.
    if (first_with_info && first_without_info)
      throw ParseError(name, line_no,
                       "some pairs have an information matrix (line " +
                           std::to_string(first_with_info) + ") and some do not (line " +
                           std::to_string(first_without_info) + "): give all pairs one or none");
    data.pairs.push_back(p);
  }
  data.has_information = first_with_info != 0;
  return data;
}

CalibrationData ReadCalibrationPairs(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  return ReadCalibrationPairs(in, path);
}

void WriteCalibrationPairs(const CalibrationData& data, std::ostream& out) {
  out << "# ux uy utheta ustar_x ustar_y ustar_theta"
      << (data.has_information ? " I11 I12 I13 I22 I23 I33" : "") << "\n";
  char buf[64];
  auto put = [&](double v) {
    std::snprintf(buf, sizeof buf, " %.17g", v);
    out << buf;
  };
  for (const CalibrationPair& p : data.pairs) {
    std::snprintf(buf, sizeof buf, "%.17g", p.u[0]);
    out << buf;
    put(p.u[1]);
    put(p.u[2]);
    for (int i = 0; i < 3; ++i) put(p.u_star[i]);
    if (data.has_information)
      for (int r = 0; r < 3; ++r)
        for (int c = r; c < 3; ++c) put(p.information(r, c));
    out << "\n";
  }
}

CalibrationData CalibrationFromGraphs(const PoseGraph& optimised, const PoseGraph& raw,
                                      bool use_edge_information) {
  if (optimised.dimension() != 2 || raw.dimension() != 2)
    throw std::invalid_argument("calibration needs planar (SE2) graphs");
  RequireNoLandmarks(optimised, "odometry calibration");
  RequireNoLandmarks(raw, "odometry calibration");
  // Odometry step from -> from + 1, keyed by `from`.
  std::map<int64_t, std::pair<Eigen::Vector3d, Eigen::Matrix3d>> steps;
  for (const Edge& e : raw.edges()) {
    if (e.kind != EdgeKind::kOdometry) continue;
    SE2 z = ToSE2(e.z);
    int64_t from = e.from;
    if (e.from == e.to + 1) {
      // The information of an inverted measurement would need the adjoint.
      if (use_edge_information)
        throw std::invalid_argument("odometry edge " + std::to_string(e.from) + " -> " +
                                    std::to_string(e.to) +
                                    " runs backwards; its information cannot be used as is");
      z = z.Inverse();
      from = e.to;
    } else if (e.to != e.from + 1) {
      continue;
    }
    if (!optimised.HasVertex(from) || !optimised.HasVertex(from + 1))
      throw std::invalid_argument("the optimised graph has no vertex " + std::to_string(from) +
                                  " or " + std::to_string(from + 1) +
                                  " for the raw odometry edge between them");
    steps[from] = {z.ToVector(), raw.Information(e).topLeftCorner<3, 3>()};
  }
  CalibrationData data;
  data.has_information = use_edge_information;
  for (const auto& [from, step] : steps) {
    CalibrationPair p;
    p.u = step.first;
    p.u_star = ToSE2(optimised.vertex(from).x).Between(ToSE2(optimised.vertex(from + 1).x)).ToVector();
    if (use_edge_information) p.information = step.second;
    data.pairs.push_back(p);
  }
  // Dead reckoning only along an unbroken chain of odometry.
  const bool chain = !steps.empty() && static_cast<int64_t>(steps.size()) ==
                                           steps.rbegin()->first - steps.begin()->first + 1;
  if (chain) {
    data.reference_poses.push_back(ToSE2(optimised.vertex(steps.begin()->first).x));
    for (const auto& [from, step] : steps) {
      data.raw_increments.push_back(step.first);
      data.reference_poses.push_back(ToSE2(optimised.vertex(from + 1).x));
    }
  }
  return data;
}

}  // namespace cairn
