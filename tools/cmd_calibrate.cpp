// cairn calibrate: the odometry-calibration matrix X (u* = X u) from increment
// pairs, a CARMEN log or a g2o result plus its raw odometry, three ways.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/calibration/odometry_calibration.h"
#include "cairn/frontend/calibration_log.h"
#include "tools/args.h"
#include "tools/read_input.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

// Beyond this the three methods are called in disagreement (the issue's bar).
constexpr double kAgreement = 1e-9;

Json CalibrationJson(const CalibrationResult& r, const std::string& source,
                     const CalibrationData& data) {
  Json j;
  j["input"] = source;
  j["pairs"] = r.pairs;
  PutMatrix(j, "X", r.x);
  PutMatrix(j, "X_std", r.x_std);
  j["std_from"] = r.covariance_from_information ? "information" : "fitted_sigma2";
  PutNumber(j, "sigma2", r.sigma2);
  PutNumber(j, "rms_before", r.rms_before);
  PutNumber(j, "rms_after", r.rms_after);
  PutMatrix(j, "rms_before_xyt", r.rms_before_xyt);
  PutMatrix(j, "rms_after_xyt", r.rms_after_xyt);
  PutNumber(j, "chi2_before", r.chi2_before);
  PutNumber(j, "chi2_after", r.chi2_after);
  PutMatrix(j, "closed_form", r.x_closed_form);
  PutMatrix(j, "gauss_newton", r.x_gauss_newton);
  j["gauss_newton_iterations"] = r.gauss_newton_iterations;
  PutMatrix(j, "ceres", r.x_ceres);
  j["ceres_termination"] = r.ceres_termination;
  PutNumber(j, "max_disagreement", r.max_disagreement);
  j["methods_agree"] = r.max_disagreement <= kAgreement;
  if (r.dead_reckoning) {
    const DeadReckoningError& d = *r.dead_reckoning;
    j["trajectory_poses"] = d.poses;
    j["steps_without_odometry"] = data.steps_without_odometry;
    PutNumber(j, "ate_rms_before", d.rms_before);
    PutNumber(j, "ate_rms_after", d.rms_after);
    PutNumber(j, "final_error_before", d.final_before);
    PutNumber(j, "final_error_after", d.final_after);
  }
  return j;
}

void PrintMatrix(const char* title, const Eigen::Matrix3d& m, const Eigen::Matrix3d* std) {
  std::printf("%s\n", title);
  for (int r = 0; r < 3; ++r) {
    std::printf("  ");
    for (int c = 0; c < 3; ++c) {
      if (std)
        std::printf(" %13.9f +- %-10.3g", m(r, c), (*std)(r, c));
      else
        std::printf(" %15.12f", m(r, c));
    }
    std::printf("\n");
  }
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

struct CalibrateArgs {
  std::string pairs_path, carmen, g2o, odometry, json, pairs_out;
  bool edge_information = false, quiet = false;
  CalibrationOptions options;
};

void DeclareOptions(ArgParser& args, CalibrateArgs& a) {
  args.Positional("PAIRS", &a.pairs_path,
                  "text file, one pair per line: ux uy utheta ustar_x ustar_y ustar_theta, "
                  "optionally followed by the 6 upper-triangle entries (row by row) of the "
                  "pair's 3x3 information matrix (all lines or none); '#' starts a comment. "
                  "A name ending in .log or .log.gz is read as a CARMEN log",
                  false);
  args.Option("carmen", &a.carmen, "LOG",
              "CARMEN log (plain or .gz): reference poses from FLASER lines, raw increments "
              "from the last ODOM before each scan, relative to the previous scan's pose");
  args.Option("g2o", &a.g2o, "OPT.g2o",
              "optimised SE2 graph: u* = between(x_i, x_i+1) of its vertices (with --odometry)");
  args.Option("odometry", &a.odometry, "RAW.g2o",
              "the raw graph whose odometry edges i -> i+1 give u (with --g2o)");
  args.Flag("edge-information", &a.edge_information,
            "with --g2o: weight each pair by its raw odometry edge's information matrix");
  args.Option("json", &a.json, "FILE",
              "write a JSON report (atomically): X, X_std (3 rows of 3), rms_before, "
              "rms_after, closed_form, gauss_newton, ceres (each method's X), "
              "max_disagreement and, with a trajectory, ate_rms_before/after and "
              "final_error_before/after (metres)");
  args.Option("pairs-out", &a.pairs_out, "FILE",
              "write the pairs used, in the text format above (atomically)");
  args.Option("degeneracy-threshold", &a.options.degeneracy_threshold, "R",
              "refuse when a direction of u is excited less than R times the strongest "
              "(eigenvalues of the diagonally normalised sum u u^T)");
  args.Flag("quiet", &a.quiet, "print nothing on success (use with --json)");
}

// Exactly one input, options that fit it; false (the error printed) if not.
// A PAIRS argument that names a CARMEN log moves to a.carmen.
bool CheckInputs(CalibrateArgs& a) {
  if (!a.pairs_path.empty() &&
      (EndsWith(a.pairs_path, ".log") || EndsWith(a.pairs_path, ".log.gz"))) {
    if (!a.carmen.empty()) {
      PrintError("give the CARMEN log once");
      return false;
    }
    a.carmen.swap(a.pairs_path);
  }
  const int sources = !a.pairs_path.empty() + !a.carmen.empty() + !a.g2o.empty();
  if (sources != 1 || a.g2o.empty() != a.odometry.empty()) {
    PrintError("give exactly one input: PAIRS.txt, --carmen LOG, or --g2o OPT.g2o with "
               "--odometry RAW.g2o");
    return false;
  }
  if (a.edge_information && a.g2o.empty()) {
    PrintError("--edge-information applies to --g2o input only");
    return false;
  }
  if (!(a.options.degeneracy_threshold >= 0 && a.options.degeneracy_threshold < 1)) {
    PrintError("--degeneracy-threshold must be in [0, 1)");
    return false;
  }
  return true;
}

// The pairs from whichever input was given; *source names it.
CalibrationData ReadData(const CalibrateArgs& a, std::string* source) {
  if (!a.pairs_path.empty()) {
    *source = a.pairs_path;
    return ReadCalibrationPairs(a.pairs_path);
  }
  if (!a.carmen.empty()) {
    *source = a.carmen;
    return ReadCarmenCalibration(a.carmen);
  }
  *source = a.g2o + " + " + a.odometry;
  return CalibrationFromGraphs(ReadInputGraph(a.g2o), ReadInputGraph(a.odometry),
                               a.edge_information);
}

void PrintSummary(const CalibrationResult& r, const std::string& source,
                  const CalibrationData& data) {
  std::printf("input            %s\n", source.c_str());
  std::printf("pairs            %zu%s\n", r.pairs, data.has_information ? " (with information)" : "");
  if (data.steps_without_odometry)
    std::printf("                 (%zu steps without odometry left out)\n",
                data.steps_without_odometry);
  PrintMatrix("X (closed form) +- standard deviation", r.x, &r.x_std);
  std::printf("  std from         %s\n",
              r.covariance_from_information
                  ? "H^-1 (information matrices given)"
                  : ("sigma^2 H^-1, sigma^2 = RSS/(3N-9) = " + std::to_string(r.sigma2)).c_str());
  PrintMatrix("X (Gauss-Newton)", r.x_gauss_newton, nullptr);
  std::printf("  iterations       %d\n", r.gauss_newton_iterations);
  PrintMatrix("X (Ceres)", r.x_ceres, nullptr);
  std::printf("  termination      %s\n", r.ceres_termination.c_str());
  std::printf("methods agree    max |difference| %.3g (%s 1e-9)\n", r.max_disagreement,
              r.max_disagreement <= kAgreement ? "within" : "NOT within");
  std::printf("residual RMS     before %.6g  after %.6g  (x, y, theta: %.4g %.4g %.4g -> "
              "%.4g %.4g %.4g)\n",
              r.rms_before, r.rms_after, r.rms_before_xyt[0], r.rms_before_xyt[1],
              r.rms_before_xyt[2], r.rms_after_xyt[0], r.rms_after_xyt[1], r.rms_after_xyt[2]);
  if (data.has_information)
    std::printf("chi2             before %.6g  after %.6g\n", r.chi2_before, r.chi2_after);
  if (r.dead_reckoning) {
    const DeadReckoningError& d = *r.dead_reckoning;
    std::printf("dead reckoning   %zu poses from the first reference pose\n", d.poses);
    std::printf("  ATE RMS (m)      before %.4f  after %.4f\n", d.rms_before, d.rms_after);
    std::printf("  final error (m)  before %.4f  after %.4f\n", d.final_before, d.final_after);
  }
}

int RunCalibrate(int argc, char** argv) {
  CalibrateArgs a;
  ArgParser args(
      "calibrate [PAIRS.txt | --carmen LOG | --g2o OPT.g2o --odometry RAW.g2o] [--json FILE]",
      "Estimates the 3x3 odometry-calibration matrix X with u* = X u in the least-squares\n"
      "sense, u = (dx, dy, dtheta) a raw odometry increment and u* the reference increment,\n"
      "both in the previous pose's frame. X is solved three ways, all reported: the closed\n"
      "form (normal equations, Cholesky), cairn's Gauss-Newton (one iteration from X = I:\n"
      "the error is linear in X) and Ceres on the same autodiff factor; they must agree to\n"
      "1e-9 or the command fails. Prints X, the residual RMS with X = I and with X, the\n"
      "standard deviation of each entry of X and, with a trajectory (CARMEN log, or g2o\n"
      "graphs whose odometry forms one chain), the dead-reckoning error before and after.\n"
      "X_std is sqrt(diag(sigma^2 H^-1)) with sigma^2 = RSS / (3N - 9) fitted from the\n"
      "residuals when no information matrices are given (none with N = 3), and\n"
      "sqrt(diag(H^-1)) when they are. Fewer than 3 pairs, or increments that never excite\n"
      "a direction (e.g. the robot never turned), are refused with an error naming it.");
  DeclareOptions(args, a);
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (!CheckInputs(a)) return 2;
  // Both outputs or neither: a calibration refused writes no pairs either.
  CommandOutputs outputs;
  for (const std::string* in : {&a.pairs_path, &a.carmen, &a.g2o, &a.odometry})
    outputs.Input(*in);
  outputs.Output(a.json);
  outputs.Output(a.pairs_out);
  outputs.Check();

  std::string source;
  const CalibrationData data = ReadData(a, &source);

  CalibrationResult r;
  try {
    r = Calibrate(data, a.options);
  } catch (const DegenerateCalibration& e) {
    PrintError(source + ": cannot calibrate: " + e.what());
    return 1;
  }
  if (!a.pairs_out.empty())
    outputs.Write(a.pairs_out, [&](std::ostream& os) { WriteCalibrationPairs(data, os); });
  if (!a.json.empty())
    outputs.Write(a.json, [&](std::ostream& os) { os << DumpJson(CalibrationJson(r, source, data)); });
  outputs.Commit();
  if (!a.quiet) PrintSummary(r, source, data);
  if (r.max_disagreement > kAgreement) {
    PrintError("the three methods disagree by " + std::to_string(r.max_disagreement) +
               " (more than 1e-9): the problem is too ill-conditioned to trust X");
    return 1;
  }
  return 0;
}

}  // namespace

CAIRN_SOLVING_COMMAND("calibrate", "odometry calibration matrix X (u* = X u), three ways", RunCalibrate);

}  // namespace cairn::tools
