// cairn compare: the Ceres path and the Gauss-Newton path side by side, from
// the same initial estimate, with how far apart their solutions are.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_difference.h"
#include "tools/args.h"
#include "tools/command.h"

namespace cairn::tools {
namespace {

std::string SolverJson(const SolveResult& r) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"initial_chi2\": %.17g, \"final_chi2\": %.17g, \"iterations\": %d, "
                "\"time_s\": %.6f, \"setup_time_s\": %.6f, \"linearize_time_s\": %.6f, "
                "\"linear_solver_time_s\": %.6f, \"termination\": \"%s\", \"linear_solver\": ",
                r.initial_chi2, r.final_chi2, r.iterations, r.time_s, r.setup_time_s,
                r.linearize_time_s, r.linear_solver_time_s, r.termination.c_str());
  return buf + JsonString(r.linear_solver) + "}";
}

// Time at which a solver's trace first reached `chi2` (relative 1e-6).
double TimeToReach(const SolveResult& r, double chi2) {
  for (const IterationRecord& it : r.trace)
    if (it.chi2 <= chi2 * (1 + 1e-6)) return it.time_s;
  return r.time_s;
}

int RunCompare(int argc, char** argv) {
  std::string path, json, robust = "none", linear_solver = "auto", sparse = "auto", init = "auto";
  bool quiet = false, no_chord = false;
  double tol_m = 1e-4, tol_deg = 1e-3, tol_chi2 = 1e-6;
  SolverOptions common;
  // Tighter than a plain optimize: two solvers agree only near the optimum.
  common.function_tolerance = 1e-15;
  common.gradient_tolerance = 1e-12;
  common.parameter_tolerance = 1e-12;
  common.max_iterations = 200;
  double damping = GaussNewtonOptions().damping;
  ArgParser args(
      "compare FILE [--json OUT.json] [--tolerance M] [options]",
      "Optimises the graph twice from the estimate in the file: with Ceres\n"
      "(Levenberg-Marquardt, sparse normal Cholesky) and with cairn's own\n"
      "Gauss-Newton path on the same factors, manifolds and gauge. Prints both\n"
      "side by side, with the largest and RMS differences between the two\n"
      "solutions. Exits 1 when they differ by more than the tolerances.");
  args.Positional("FILE", &path, "a .g2o or TORO .graph file");
  args.Option("json", &json, "FILE", "also write the comparison as JSON");
  args.Option("tolerance", &tol_m, "M", "largest translation difference accepted, m");
  args.Option("rotation-tolerance", &tol_deg, "DEG", "largest rotation difference accepted, degrees");
  args.Option("chi2-tolerance", &tol_chi2, "REL", "largest relative final chi2 difference accepted");
  args.Option("max-iterations", &common.max_iterations, "N", "iteration limit for both");
  args.Option("function-tolerance", &common.function_tolerance, "TOL",
              "both stop when one step lowers chi2 by less than this fraction");
  args.Option("gradient-tolerance", &common.gradient_tolerance, "TOL",
              "both stop when the largest gradient component is below this times chi2 per "
              "residual");
  args.Option("parameter-tolerance", &common.parameter_tolerance, "TOL",
              "both stop when the step is this small relative to the estimate");
  args.Option("threads", &common.threads, "N", "threads for both (0: one per core)");
  args.Option("robust", &robust, "KIND:DELTA", "robust loss on loop closures for both");
  args.Option("linear-solver", &linear_solver, "NAME",
              "gn: auto (with 2+ threads a large graph is cut in two halves factorised at once, else CHOLMOD picks supernodal or simplicial per matrix), parallel, supernodal, simplicial, cholmod-auto or eigen");
  args.Option("gn-damping", &damping, "LAMBDA",
              "gn: Levenberg-Marquardt damping (times diag H) the fallback starts from, 1/radius as in Ceres");
  args.Option("sparse", &sparse, "LIB", "ceres: auto, suitesparse, eigen or cxsparse");
  args.Option("init", &init, "METHOD",
              "initial estimate for both: auto (the default: the file's vertices, or the "
              "chordal relaxation when its chi2 is lower), file (the file's vertices), odometry "
              "(chained odometry), spanning-tree (chained along the most certain edges) or "
              "chordal (chordal relaxation of the rotations, then linear translations)");
  args.Flag("gn-no-chord", &no_chord,
            "gn: factorise at every step (no steps with an earlier factorisation)");
  args.Flag("quiet", &quiet, "no per-iteration progress lines");
  int repeat = 1;
  args.Option("repeat", &repeat, "N",
              "solve N times with each solver, alternating which goes first, and report each "
              "one's fastest run: the first run in a process pays for fresh memory");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (repeat < 1) {
    std::fprintf(stderr, "cairn compare: --repeat must be at least 1\n");
    return 2;
  }
  common.loop_closure_loss = ParseRobustLoss(robust);
  common.verbose = !quiet;
  CeresOptions co;
  static_cast<SolverOptions&>(co) = common;
  co.sparse_library = ParseSparseLibrary(sparse);
  GaussNewtonOptions go;
  static_cast<SolverOptions&>(go) = common;
  go.linear_solver = ParseCholeskyKind(linear_solver);
  go.damping = damping;
  go.reuse_factorization = !no_chord;

  ReadOptions ro;
  ro.warnings = &std::cerr;
  const InitMethod init_method = ParseInitMethod(init);
  PoseGraph input = ReadGraph(path, ro);
  const InitReport init_report = Initialize(input, init_method);
  if (!quiet)
    std::fprintf(stderr, "initial estimate: %s, %.4f s, chi2 %.10g\n", ToString(init_method),
                 init_report.time_s, init_report.chi2);
  PoseGraph ceres_graph = input, gn_graph = input;
  SolveResult c, g;
  for (int round = 0; round < repeat; ++round) {
    // Progress lines for the first round only; the others are for timing.
    co.verbose = go.verbose = !quiet && round == 0;
    auto run_ceres = [&] {
      if (co.verbose) std::fprintf(stderr, "-- ceres --\n");
      PoseGraph graph = input;
      SolveResult r = SolveWithCeres(graph, co);
      if (round == 0 || r.time_s < c.time_s) c = std::move(r), ceres_graph = std::move(graph);
    };
    auto run_gn = [&] {
      if (go.verbose) std::fprintf(stderr, "-- gn (%s) --\n", ToString(go.linear_solver));
      PoseGraph graph = input;
      SolveResult r = SolveGaussNewton(graph, go);
      if (round == 0 || r.time_s < g.time_s) g = std::move(r), gn_graph = std::move(graph);
    };
    if (round % 2 == 0) {
      run_ceres();
      run_gn();
    } else {
      run_gn();
      run_ceres();
    }
  }
  if (repeat > 1)
    std::fprintf(stderr, "times: the fastest of %d runs of each solver, in alternating order\n",
                 repeat);
  const PoseDifference d = ComparePoses(ceres_graph, gn_graph);
  const double chi2_rel = std::abs(c.final_chi2 - g.final_chi2) / std::max(c.final_chi2, 1e-300);

  std::printf("%s: %zu vertices, %zu edges\n", path.c_str(), input.vertices().size(),
              input.edges().size());
  if (init_method == InitMethod::kAuto) std::printf("%s\n", DescribeAutoChoice(init_report).c_str());
  std::printf("%-24s %16s %16s\n", "", "ceres", "gn");
  std::printf("%-24s %16.10g %16.10g\n", "initial chi2", c.initial_chi2, g.initial_chi2);
  std::printf("%-24s %16.10g %16.10g\n", "final chi2", c.final_chi2, g.final_chi2);
  std::printf("%-24s %16d %16d\n", "iterations", c.iterations, g.iterations);
  std::printf("%-24s %16.4f %16.4f\n", "setup s", c.setup_time_s, g.setup_time_s);
  std::printf("%-24s %16.4f %16.4f\n", "linearisation s", c.linearize_time_s, g.linearize_time_s);
  std::printf("%-24s %16.4f %16.4f\n", "linear solver s", c.linear_solver_time_s,
              g.linear_solver_time_s);
  std::printf("%-24s %16.4f %16.4f\n", "total s", c.time_s, g.time_s);
  const double target = std::max(c.final_chi2, g.final_chi2);
  std::printf("%-24s %16.4f %16.4f\n", "s to reach both's chi2", TimeToReach(c, target),
              TimeToReach(g, target));
  std::printf("%-24s %16s %16.4f\n", "s to reach ceres's chi2", "", TimeToReach(g, c.final_chi2));
  std::printf("%-24s %16s %16s\n", "termination", c.termination.c_str(), g.termination.c_str());
  std::printf("difference: final chi2 %.3g relative; translation max %.3g m, rms %.3g m; "
              "rotation max %.3g deg, rms %.3g deg\n",
              chi2_rel, d.max_translation, d.rms_translation, d.max_rotation_deg,
              d.rms_rotation_deg);
  std::printf("time ratio gn/ceres: %.3f\n", g.time_s / std::max(c.time_s, 1e-12));

  if (!json.empty()) {
    WriteFileAtomically(json, [&](std::ostream& os) {
      char buf[768];
      std::snprintf(buf, sizeof buf,
                    "\"max_translation_diff\": %.6g, \"rms_translation_diff\": %.6g, "
                    "\"max_rotation_diff_deg\": %.6g, \"rms_rotation_diff_deg\": %.6g, "
                    "\"final_chi2_relative_diff\": %.6g, \"time_ratio_gn_over_ceres\": %.6g, "
                    "\"gn_time_to_reach_ceres_s\": %.6f",
                    d.max_translation, d.rms_translation, d.max_rotation_deg,
                    d.rms_rotation_deg, chi2_rel, g.time_s / std::max(c.time_s, 1e-12),
                    TimeToReach(g, c.final_chi2));
      char init_buf[256];
      std::snprintf(init_buf, sizeof init_buf,
                    "{\"method\": \"%s\", \"time_s\": %.6f, \"chi2\": %.17g}",
                    ToString(init_method), init_report.time_s, init_report.chi2);
      std::string init_json = init_buf;
      if (init_method == InitMethod::kAuto) {
        char chordal[32] = "null", more[160];  // null: its systems were singular
        if (!std::isnan(init_report.chordal_chi2))
          std::snprintf(chordal, sizeof chordal, "%.17g", init_report.chordal_chi2);
        std::snprintf(more, sizeof more,
                      ", \"chosen\": \"%s\", \"file_chi2\": %.17g, \"chordal_chi2\": %s}",
                      ToString(init_report.chosen), init_report.file_chi2, chordal);
        init_json = init_json.substr(0, init_json.size() - 1) + more;
      }
      os << "{\"file\": \"" << path << "\", \"init\": " << init_json
         << ", \"ceres\": " << SolverJson(c)
         << ", \"gn\": " << SolverJson(g) << ", " << buf << "}\n";
    });
  }
  const bool agree = d.max_translation <= tol_m && d.max_rotation_deg <= tol_deg &&
                     chi2_rel <= tol_chi2;
  if (!agree) {
    std::printf("the solutions differ by more than the tolerances (%.3g m, %.3g deg, %.3g)\n",
                tol_m, tol_deg, tol_chi2);
    return 1;
  }
  std::printf("the solutions agree within %.3g m, %.3g deg and %.3g relative chi2\n", tol_m,
              tol_deg, tol_chi2);
  return 0;
}

}  // namespace

CAIRN_COMMAND("compare", "run the Ceres and Gauss-Newton paths side by side", RunCompare);

}  // namespace cairn::tools
