// cairn calibrate: the odometry-calibration matrix X (u* = X u) from increment
// pairs, a CARMEN log or a g2o result plus its raw odometry, three ways.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/calibration/odometry_calibration.h"
#include "cairn/frontend/calibration_log.h"
#include "tools/args.h"
#include "tools/command.h"

namespace cairn::tools {
namespace {

// Beyond this the three methods are called in disagreement (the issue's bar).
constexpr double kAgreement = 1e-9;

std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string JsonMatrix(const Eigen::Matrix3d& m) {
  std::string s = "[";
  for (int r = 0; r < 3; ++r) {
    s += r ? ", [" : "[";
    for (int c = 0; c < 3; ++c) s += (c ? ", " : "") + JsonNumber(m(r, c));
    s += "]";
  }
  return s + "]";
}

std::string JsonVector(const Eigen::Vector3d& v) {
  return "[" + JsonNumber(v[0]) + ", " + JsonNumber(v[1]) + ", " + JsonNumber(v[2]) + "]";
}

std::string JsonString(const std::string& text) {
  std::string s = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') s += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    s += c;
  }
  return s + "\"";
}

void WriteJson(std::ostream& os, const CalibrationResult& r, const std::string& source,
               const CalibrationData& data) {
  os << "{\n  \"input\": " << JsonString(source) << ",\n";
  os << "  \"pairs\": " << r.pairs << ",\n";
  os << "  \"X\": " << JsonMatrix(r.x) << ",\n";
  os << "  \"X_std\": " << JsonMatrix(r.x_std) << ",\n";
  os << "  \"std_from\": "
     << (r.covariance_from_information ? "\"information\"" : "\"fitted_sigma2\"") << ",\n";
  os << "  \"sigma2\": " << JsonNumber(r.sigma2) << ",\n";
  os << "  \"rms_before\": " << JsonNumber(r.rms_before) << ",\n";
  os << "  \"rms_after\": " << JsonNumber(r.rms_after) << ",\n";
  os << "  \"rms_before_xyt\": " << JsonVector(r.rms_before_xyt) << ",\n";
  os << "  \"rms_after_xyt\": " << JsonVector(r.rms_after_xyt) << ",\n";
  os << "  \"chi2_before\": " << JsonNumber(r.chi2_before) << ",\n";
  os << "  \"chi2_after\": " << JsonNumber(r.chi2_after) << ",\n";
  os << "  \"closed_form\": " << JsonMatrix(r.x_closed_form) << ",\n";
  os << "  \"gauss_newton\": " << JsonMatrix(r.x_gauss_newton) << ",\n";
  os << "  \"gauss_newton_iterations\": " << r.gauss_newton_iterations << ",\n";
  os << "  \"ceres\": " << JsonMatrix(r.x_ceres) << ",\n";
  os << "  \"ceres_termination\": " << JsonString(r.ceres_termination) << ",\n";
  os << "  \"max_disagreement\": " << JsonNumber(r.max_disagreement) << ",\n";
  os << "  \"methods_agree\": " << (r.max_disagreement <= kAgreement ? "true" : "false");
  if (r.dead_reckoning) {
    const DeadReckoningError& d = *r.dead_reckoning;
    os << ",\n  \"trajectory_poses\": " << d.poses << ",\n";
    os << "  \"steps_without_odometry\": " << data.steps_without_odometry << ",\n";
    os << "  \"ate_rms_before\": " << JsonNumber(d.rms_before) << ",\n";
    os << "  \"ate_rms_after\": " << JsonNumber(d.rms_after) << ",\n";
    os << "  \"final_error_before\": " << JsonNumber(d.final_before) << ",\n";
    os << "  \"final_error_after\": " << JsonNumber(d.final_after);
  }
  os << "\n}\n";
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

int RunCalibrate(int argc, char** argv) {
  std::string pairs_path, carmen, g2o, odometry, json, pairs_out;
  bool edge_information = false, quiet = false;
  CalibrationOptions options;
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
  args.Positional("PAIRS", &pairs_path,
                  "text file, one pair per line: ux uy utheta ustar_x ustar_y ustar_theta, "
                  "optionally followed by the 6 upper-triangle entries (row by row) of the "
                  "pair's 3x3 information matrix (all lines or none); '#' starts a comment. "
                  "A name ending in .log or .log.gz is read as a CARMEN log",
                  false);
  args.Option("carmen", &carmen, "LOG",
              "CARMEN log (plain or .gz): reference poses from FLASER lines, raw increments "
              "from the last ODOM before each scan, relative to the previous scan's pose");
  args.Option("g2o", &g2o, "OPT.g2o",
              "optimised SE2 graph: u* = between(x_i, x_i+1) of its vertices (with --odometry)");
  args.Option("odometry", &odometry, "RAW.g2o",
              "the raw graph whose odometry edges i -> i+1 give u (with --g2o)");
  args.Flag("edge-information", &edge_information,
            "with --g2o: weight each pair by its raw odometry edge's information matrix");
  args.Option("json", &json, "FILE",
              "write a JSON report (atomically): X, X_std (3 rows of 3), rms_before, "
              "rms_after, closed_form, gauss_newton, ceres (each method's X), "
              "max_disagreement and, with a trajectory, ate_rms_before/after and "
              "final_error_before/after (metres)");
  args.Option("pairs-out", &pairs_out, "FILE",
              "write the pairs used, in the text format above (atomically)");
  args.Option("degeneracy-threshold", &options.degeneracy_threshold, "R",
              "refuse when a direction of u is excited less than R times the strongest "
              "(eigenvalues of the diagonally normalised sum u u^T)");
  args.Flag("quiet", &quiet, "print nothing on success (use with --json)");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;

  if (!pairs_path.empty() && (EndsWith(pairs_path, ".log") || EndsWith(pairs_path, ".log.gz"))) {
    if (!carmen.empty()) {
      PrintError("give the CARMEN log once");
      return 2;
    }
    carmen.swap(pairs_path);
  }
  const int sources = !pairs_path.empty() + !carmen.empty() + !g2o.empty();
  if (sources != 1 || g2o.empty() != odometry.empty()) {
    PrintError("give exactly one input: PAIRS.txt, --carmen LOG, or --g2o OPT.g2o with "
               "--odometry RAW.g2o");
    return 2;
  }
  if (edge_information && g2o.empty()) {
    PrintError("--edge-information applies to --g2o input only");
    return 2;
  }
  if (!(options.degeneracy_threshold >= 0 && options.degeneracy_threshold < 1)) {
    PrintError("--degeneracy-threshold must be in [0, 1)");
    return 2;
  }

  CalibrationData data;
  std::string source;
  if (!pairs_path.empty()) {
    data = ReadCalibrationPairs(pairs_path);
    source = pairs_path;
  } else if (!carmen.empty()) {
    data = ReadCarmenCalibration(carmen);
    source = carmen;
  } else {
    ReadOptions ro;
    ro.keep_unknown = Globals().keep_unknown;
    data = CalibrationFromGraphs(ReadGraph(g2o, ro), ReadGraph(odometry, ro), edge_information);
    source = g2o + " + " + odometry;
  }
  if (!pairs_out.empty())
    WriteFileAtomically(pairs_out, [&](std::ostream& os) { WriteCalibrationPairs(data, os); });

  CalibrationResult r;
  try {
    r = Calibrate(data, options);
  } catch (const DegenerateCalibration& e) {
    PrintError(source + ": cannot calibrate: " + e.what());
    return 1;
  }
  if (!json.empty())
    WriteFileAtomically(json, [&](std::ostream& os) { WriteJson(os, r, source, data); });

  if (!quiet) {
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
  if (r.max_disagreement > kAgreement) {
    PrintError("the three methods disagree by " + std::to_string(r.max_disagreement) +
               " (more than 1e-9): the problem is too ill-conditioned to trust X");
    return 1;
  }
  return 0;
}

}  // namespace

CAIRN_COMMAND("calibrate", "odometry calibration matrix X (u* = X u), three ways", RunCalibrate);

}  // namespace cairn::tools
