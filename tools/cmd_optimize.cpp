// cairn optimize: read a pose graph, optimise it, write it as g2o.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/solvers/covariance.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/initialization.h"
#include "cairn/robust/outliers.h"
#include "cairn/solvers/solve_result.h"
#include "cairn/graph/svg_plot.h"
#include "tools/args.h"
#include "tools/command.h"

namespace cairn::tools {
namespace {

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// The marginal covariances as a JSON object {"id": [[row], ...], ...}.
std::string CovarianceJson(const std::vector<int64_t>& ids, const std::vector<Eigen::MatrixXd>& cov) {
  std::ostringstream os;
  os << "{";
  for (size_t k = 0; k < ids.size(); ++k) {
    os << (k ? ",\n    " : "\n    ") << "\"" << ids[k] << "\": [";
    for (int i = 0; i < cov[k].rows(); ++i) {
      os << (i ? ", [" : "[");
      for (int j = 0; j < cov[k].cols(); ++j) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.17g", cov[k](i, j));
        os << (j ? ", " : "") << buf;
      }
      os << "]";
    }
    os << "]";
  }
  os << "\n  }";
  return os.str();
}

int RunOptimize(int argc, char** argv) {
  std::string in, out, solver = "ceres", robust = "none", method = "lm", sparse = "auto";
  std::string init;  // auto, or file with --reject-outliers
  std::string report, plot, linear_solver = "auto";
  bool quiet = false, strict = false, no_jacobi = false;
  // The common options (SolverOptions) live in the Ceres struct; --solver gn
  // copies them over.
  CeresOptions o;
  double gn_damping = GaussNewtonOptions().damping;
  bool gn_no_chord = false;
  ArgParser args(
      "optimize IN -o OUT.g2o [--solver ceres|gn] [--robust huber:D|cauchy:D|dcs:PHI] [options]",
      "Optimises a g2o or TORO pose graph from the estimate in the file and writes the\n"
      "result as g2o (to a temporary file, renamed when complete). Vertices marked\n"
      "FIX stay put; when none is and no prior anchors the graph, the lowest-id\n"
      "vertex is held. Progress goes to stderr, one line per iteration (chi2 is\n"
      "g2o's: twice Ceres's cost, robustified when --robust is set). Options marked\n"
      "ceres: or gn: apply to that solver only.");
  args.Positional("IN", &in, "a .g2o or TORO .graph file");
  args.Option("output", &out, "OUT.g2o", "where to write the optimised graph (g2o)");
  args.Alias("-o", "output");
  args.Option("solver", &solver, "NAME",
              "ceres (Ceres's trust-region solver) or gn (cairn's own Gauss-Newton, "
              "damped only when a step fails)");
  args.Option("method", &method, "lm|dogleg",
              "ceres: Levenberg-Marquardt or Powell's dogleg trust region");
  args.Option("sparse", &sparse, "LIB",
              "ceres: sparse Cholesky library: auto (per graph, see docs/benchmarks.md), "
              "suitesparse (CHOLMOD), eigen (simplicial LDLT), cxsparse");
  args.Option("max-iterations", &o.max_iterations, "N", "stop after N iterations");
  args.Option("robust", &robust, "KIND:DELTA",
              "robust loss on loop closures: none, huber:DELTA, cauchy:DELTA (DELTA on the "
              "whitened error, as g2o's kernels) or dcs:PHI (dynamic covariance scaling, PHI "
              "on chi2)");
  args.Option("threads", &o.threads, "N", "threads for linearisation (0: one per core)");
  args.Option("function-tolerance", &o.function_tolerance, "TOL",
              "stop when one step lowers chi2 by less than this fraction");
  args.Option("gradient-tolerance", &o.gradient_tolerance, "TOL",
              "stop when the largest gradient component is below this times chi2 per residual");
  args.Option("parameter-tolerance", &o.parameter_tolerance, "TOL",
              "stop when the step is this small relative to the estimate");
  args.Option("initial-radius", &o.initial_trust_region_radius, "R",
              "ceres: first trust-region radius (large: start close to Gauss-Newton)");
  args.Option("min-lm-diagonal", &o.min_lm_diagonal, "D",
              "ceres: lower bound on Levenberg-Marquardt's diagonal damping (times the "
              "largest information entry when that is below 1)");
  args.Flag("postordering", &o.use_postordering,
            "ceres: let the sparse Cholesky order the normal matrix itself (AMD with "
            "postordering) instead of pre-permuting the Jacobian");
  args.Flag("no-jacobi-scaling", &no_jacobi, "ceres: do not scale columns of the Jacobian");
  args.Option("linear-solver", &linear_solver, "NAME",
              "gn: auto, parallel, supernodal, simplicial, cholmod-auto or eigen");
  args.Flag("gn-no-chord", &gn_no_chord,
            "gn: factorise at every step (no steps with an earlier factorisation)");
  args.Option("gn-damping", &gn_damping, "LAMBDA",
              "gn: Levenberg-Marquardt damping (times diag H) the fallback starts from, 1/radius as in Ceres");
  args.Option("report", &report, "FILE.json",
              "write a JSON report: initial_chi2, final_chi2, iterations, time_s, "
              "termination, timings and the per-iteration trace");
  std::string covariance_ids;  // "3,17,42"
  args.Option("covariance", &covariance_ids, "IDS",
              "print the marginal covariances (tangent space, the pose's own frame) of these "
              "vertices at the optimum, e.g. 3,17,42, and add them to the --report JSON");
  args.Option("plot", &plot, "FILE.svg",
              "draw the trajectory before and after, loop closures in red (3D: x-y view)");
  bool reject_outliers = false;
  OutlierRejectionOptions rejection;
  args.Flag("reject-outliers", &reject_outliers,
            "decide which loop closures are wrong (graduated non-convexity, truncated least "
            "squares) and drop them; the report lists them as rejected_loop_closures");
  args.Option("outlier-threshold", &rejection.threshold_chi2, "CHI2",
              "with --reject-outliers: the chi2 above which a loop closure is wrong (0: the "
              "--outlier-confidence quantile for 3 or 6 dof)");
  args.Option("outlier-confidence", &rejection.confidence, "P",
              "with --reject-outliers: quantile of chi2 taken as the threshold");
  args.Option("gnc-iterations", &rejection.inner_iterations, "N",
              "with --reject-outliers: iterations of each weighted solve inside GNC (0: "
              "--max-iterations); the solves without the rejected ones run in full");
  args.Option("outlier-window", &rejection.consistency_window, "N",
              "with --reject-outliers: loop closures whose ends lie within N ids of another's "
              "that agrees with them go through GNC first, alone (0: no such stage)");
  args.Option("outlier-restart", &rejection.restart_chi2_factor, "F",
              "with --reject-outliers: after that stage, GNC over all loop closures starts "
              "with those beyond F times the threshold at weight 0");
  bool no_readmit = false;
  args.Flag("no-outlier-readmission", &no_readmit,
            "with --reject-outliers: do not take back rejected loop closures whose "
            "innovation statistic at the final estimate is within the threshold");
  bool no_verify = false;
  args.Flag("no-outlier-verification", &no_verify,
            "with --reject-outliers: skip the check after GNC (kept loop closures whose "
            "deletion would lower chi2 by more than the threshold are rejected too)");
  args.Option("init", &init, "METHOD",
              "initial estimate: auto (the default: the file's vertices, or the chordal "
              "relaxation when its chi2 is lower; with --reject-outliers the default is file, "
              "since wrong loop closures bend the relaxation), file (the file's vertices), odometry "
              "(chained odometry), spanning-tree (chained along the most certain edges) or "
              "chordal (chordal relaxation of the rotations, then linear translations)");
  args.Flag("quiet", &quiet, "no progress lines and no summary");
  args.Flag("strict", &strict, "refuse tags cairn does not know instead of skipping them");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (out.empty()) {
    PrintError("optimize needs an output file (-o OUT.g2o)");
    return 2;
  }
  if (solver != "ceres" && solver != "gn") {
    PrintError("unknown solver '" + solver + "' (expected ceres or gn)");
    return 2;
  }
  GaussNewtonOptions gn;
  try {
    gn.linear_solver = ParseCholeskyKind(linear_solver);
    o.loop_closure_loss = ParseRobustLoss(robust);
    o.method = ParseCeresMethod(method);
    o.sparse_library = ParseSparseLibrary(sparse);
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return 2;
  }
  if (o.max_iterations < 0 || o.threads < 0) {
    PrintError("--max-iterations and --threads must not be negative");
    return 2;
  }
  o.verbose = !quiet;
  o.jacobi_scaling = !no_jacobi;
  static_cast<SolverOptions&>(gn) = o;
  gn.damping = gn_damping;
  gn.reuse_factorization = !gn_no_chord;

  std::vector<int64_t> covariance_of;
  if (!covariance_ids.empty()) {
    try {
      covariance_of = ParseIdList(covariance_ids);
    } catch (const std::invalid_argument& e) {
      PrintError(std::string("--covariance: ") + e.what());
      return 2;
    }
  }

  // Outlier rejection trusts its start, and the chordal relaxation takes in
  // every loop closure, wrong ones included.
  if (init.empty()) init = reject_outliers ? "file" : "auto";
  InitMethod init_method;
  try {
    init_method = ParseInitMethod(init);
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return 2;
  }
  ReadOptions read_options;
  read_options.strict = strict;
  read_options.warnings = &std::cerr;
  const auto read_start = std::chrono::steady_clock::now();
  PoseGraph graph = ReadGraph(in, read_options);
  const double read_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
  // Only copied when asked for: the "before" panel of the plot, the file's
  // own estimate whatever the initialisation.
  const PoseGraph before = plot.empty() ? PoseGraph(graph.dimension()) : graph;
  const InitReport init_report = Initialize(graph, init_method);
  if (!quiet && init_method != InitMethod::kFile)
    std::fprintf(stderr, "initial estimate: %s, %.4f s, chi2 %.10g\n", ToString(init_method),
                 init_report.time_s, init_report.chi2);
  if (!quiet && init_method == InitMethod::kAuto) std::printf("%s\n", DescribeAutoChoice(init_report).c_str());

  std::vector<VertexPair> rejected;
  SolveResult result;
  if (reject_outliers) {
    if (!(rejection.confidence > 0 && rejection.confidence < 1) || rejection.threshold_chi2 < 0) {
      PrintError("--outlier-confidence must lie in (0, 1) and --outlier-threshold be >= 0");
      return 2;
    }
    if (rejection.inner_iterations < 0 || rejection.consistency_window < 0 ||
        !(rejection.restart_chi2_factor > 1)) {
      PrintError("--gnc-iterations and --outlier-window must not be negative, --outlier-restart "
                 "must exceed 1");
      return 2;
    }
    rejection.verify = !no_verify;
    rejection.readmit = !no_readmit;
    // The inner solves are many: one progress line per GNC round instead.
    rejection.verbose = !quiet;
    CeresOptions inner = o;
    GaussNewtonOptions inner_gn = gn;
    inner.verbose = inner_gn.verbose = false;
    const OutlierRejectionResult r = SolveRejectingOutliers(
        graph,
        [&](PoseGraph& g, int max_iterations) {
          CeresOptions c = inner;
          GaussNewtonOptions n = inner_gn;
          if (max_iterations > 0) c.max_iterations = n.max_iterations = max_iterations;
          return solver == "gn" ? SolveGaussNewton(g, n) : SolveWithCeres(g, c);
        },
        rejection);
    result = r.solve;
    rejected = r.rejected;
    if (!quiet)
      std::fprintf(stderr,
                   "%s: rejected %zu of %zu loop closures (%d of them by verification; chi2 "
                   "threshold %.4g, %d solves)\n",
                   in.c_str(), rejected.size(), graph.CountEdges(EdgeKind::kLoopClosure),
                   r.verified, r.threshold_chi2, r.rounds);
  } else {
    result = solver == "gn" ? SolveGaussNewton(graph, gn) : SolveWithCeres(graph, o);
  }
  // A failed solve leaves no output behind (the report still says why).
  if (result.usable) WriteFileAtomically(out, [&](std::ostream& os) { WriteG2o(graph, os); });

  std::vector<Eigen::MatrixXd> covariances;
  // Not from a failed solve: the estimate is no optimum.
  if (!covariance_of.empty() && result.usable) {
    // From the solver that found the optimum (Ceres's ceres::Covariance, or
    // the Gauss-Newton factorisation); tests/test_covariance.cpp checks that
    // the two agree.
    const SolverKind kind = solver == "gn" ? SolverKind::kGaussNewton : SolverKind::kCeres;
    try {
      covariances = MarginalCovariances(graph, covariance_of, kind, o.loop_closure_loss);
    } catch (const std::exception& e) {
      PrintError(std::string("--covariance: ") + e.what());
      return 1;
    }
    for (size_t k = 0; k < covariance_of.size(); ++k) {
      std::printf("vertex %lld covariance (%s, own frame)%s:\n",
                  static_cast<long long>(covariance_of[k]),
                  graph.dimension() == 2 ? "dx dy dtheta" : "dx dy dz wx wy wz",
                  covariances[k].isZero() ? " [held: the gauge or fixed]" : "");
      for (int i = 0; i < covariances[k].rows(); ++i) {
        for (int j = 0; j < covariances[k].cols(); ++j) std::printf(" %14.6e", covariances[k](i, j));
        std::printf("\n");
      }
    }
  }

  if (!report.empty()) {
    std::vector<std::pair<std::string, std::string>> context = {
        {"input", in},
        {"output", out},
        {"dimension", std::to_string(graph.dimension())},
        {"vertices", std::to_string(graph.vertices().size())},
        {"edges", std::to_string(graph.edges().size())},
        {"loop_closures", std::to_string(graph.CountEdges(EdgeKind::kLoopClosure))},
        {"robust", ToString(o.loop_closure_loss)},
        {"method", solver == "gn" ? "gauss-newton" : method},
        {"sparse", solver == "gn" ? linear_solver : sparse},
        {"read_time_s", Number(read_time)},
        {"init", ToString(init_method)},
        {"init_time_s", Number(init_report.time_s)},
        {"init_chi2", Number(init_report.chi2)},
    };
    if (init_method == InitMethod::kAuto) {
      context.emplace_back("init_chosen", ToString(init_report.chosen));
      context.emplace_back("init_file_chi2", Number(init_report.file_chi2));
      context.emplace_back("init_chordal_chi2", Number(init_report.chordal_chi2));
    }
    std::ostringstream json;
    WriteReportJson(result, json, context);
    std::string text = json.str();
    if (reject_outliers) {
      // An array has no place among the string-valued context: spliced in
      // after the opening brace.
      std::string pairs = "  \"rejected_loop_closures\": [";
      for (size_t i = 0; i < rejected.size(); ++i)
        pairs += (i ? ", [" : "[") + std::to_string(rejected[i].first) + ", " +
                 std::to_string(rejected[i].second) + "]";
      text.insert(text.find('{') + 2, pairs + "],\n");
    }
    if (!covariances.empty()) {
      // Spliced in before the closing brace: the shared report writer knows
      // nothing of covariances.
      const size_t brace = text.find_last_of('}');
      const size_t end = text.find_last_not_of(" \n", brace - 1) + 1;
      text = text.substr(0, end) + ",\n  \"covariance\": " +
             CovarianceJson(covariance_of, covariances) + "\n}\n";
    }
    WriteFileAtomically(report, [&](std::ostream& os) { os << text; });
  }
  if (!plot.empty()) {
    PlotPanel a{&before, "before: chi2 " + Number(Chi2(before)), "#888888"};
    PlotPanel b{&graph, "after: chi2 " + Number(result.final_chi2)};
    WriteFileAtomically(plot, [&](std::ostream& os) { WriteSvgPlot(os, {a, b}, in); });
  }
  if (!quiet) {
    std::fprintf(stderr, "%s: chi2 %.10g -> %.10g, %d iterations, %.3f s (%s)\n", in.c_str(),
                 result.initial_chi2, result.final_chi2, result.iterations, result.time_s,
                 result.termination.c_str());
  }
  if (!result.usable) {
    PrintError("the solver failed, " + out + " not written: " + result.message);
    return 1;
  }
  return 0;
}

}  // namespace

CAIRN_COMMAND("optimize", "optimise a pose graph (Ceres or Gauss-Newton), write it as g2o",
              RunOptimize);

}  // namespace cairn::tools
