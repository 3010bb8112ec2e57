// cairn compare: the Ceres path and the Gauss-Newton path side by side, from
// the same initial estimate, with how far apart their solutions are.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_difference.h"
#include "tools/args.h"
#include "tools/read_input.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

Json SolverJson(const SolveResult& r) {
  Json j;
  PutNumber(j, "initial_chi2", r.initial_chi2);
  PutNumber(j, "final_chi2", r.final_chi2);
  j["iterations"] = r.iterations;
  PutNumber(j, "time_s", r.time_s);
  PutNumber(j, "setup_time_s", r.setup_time_s);
  PutNumber(j, "linearize_time_s", r.linearize_time_s);
  PutNumber(j, "linear_solver_time_s", r.linear_solver_time_s);
  j["termination"] = r.termination;
  j["linear_solver"] = r.linear_solver;
  return j;
}

// Time at which a solver's trace first reached `chi2` (relative 1e-6).
double TimeToReach(const SolveResult& r, double chi2) {
  for (const IterationRecord& it : r.trace)
    if (it.chi2 <= chi2 * (1 + 1e-6)) return it.time_s;
  return r.time_s;
}

struct CompareArgs {
  std::string path, json, robust = "none", linear_solver = "auto", sparse = "auto", init = "auto";
  bool quiet = false, no_chord = false;
  std::string factor_memory = "auto";
  double tol_m = 1e-4, tol_deg = 1e-3, tol_chi2 = 1e-6;
  SolverOptions common;
  double damping = GaussNewtonOptions().damping;
  int repeat = 1;

  CompareArgs() {
    // Tighter than a plain optimize: two solvers agree only near the optimum.
    common.function_tolerance = 1e-15;
    common.gradient_tolerance = 1e-12;
    common.parameter_tolerance = 1e-12;
    common.max_iterations = 200;
  }
};

void DeclareOptions(ArgParser& args, CompareArgs& a) {
  args.Positional("FILE", &a.path, "a .g2o or TORO .graph file");
  args.Option("json", &a.json, "FILE", "also write the comparison as JSON (with repaired_information)");
  args.Option("tolerance", &a.tol_m, "M", "largest translation difference accepted, m");
  args.Option("rotation-tolerance", &a.tol_deg, "DEG", "largest rotation difference accepted, degrees");
  args.Option("chi2-tolerance", &a.tol_chi2, "REL", "largest relative final chi2 difference accepted");
  args.Option("max-iterations", &a.common.max_iterations, "N", "iteration limit for both");
  args.Option("function-tolerance", &a.common.function_tolerance, "TOL",
              "both stop when one step lowers chi2 by less than this fraction");
  args.Option("gradient-tolerance", &a.common.gradient_tolerance, "TOL",
              "both stop when the largest gradient component is below this times chi2 per "
              "residual");
  args.Option("parameter-tolerance", &a.common.parameter_tolerance, "TOL",
              "both stop when the step is this small relative to the estimate");
  args.Option("threads", &a.common.threads, "N", "threads for both (0: one per core)");
  args.Option("robust", &a.robust, "KIND:DELTA", "robust loss on loop closures for both");
  args.Option("linear-solver", &a.linear_solver, "NAME",
              "gn: auto (with 2+ threads a large graph is cut in two halves factorised at once, else CHOLMOD picks supernodal or simplicial per matrix), parallel, supernodal, simplicial, cholmod-auto or eigen");
  args.Option("gn-damping", &a.damping, "LAMBDA",
              "gn: Levenberg-Marquardt damping (times diag H) the fallback starts from, 1/radius as in Ceres");
  args.Option("sparse", &a.sparse, "LIB", "ceres: auto, suitesparse, eigen or cxsparse");
  args.Option("init", &a.init, "METHOD",
              "initial estimate for both: auto (the default: the file's vertices, or the "
              "chordal relaxation when its chi2 is lower), file (the file's vertices), odometry "
              "(chained odometry), spanning-tree (chained along the most certain edges) or "
              "chordal (chordal relaxation of the rotations, then linear translations)");
  args.Flag("gn-no-chord", &a.no_chord,
            "gn: factorise at every step (no steps with an earlier factorisation)");
  args.Option("gn-factor-memory", &a.factor_memory, "MB",
              "gn: the most the two-halves factorisation's factors may hold in memory (auto, "
              "unlimited or MB; as in optimize)");
  args.Flag("quiet", &a.quiet, "no per-iteration progress lines");
  args.Option("repeat", &a.repeat, "N",
              "solve N times with each solver, alternating which goes first, and report each "
              "one's fastest run: the first run in a process pays for fresh memory");
}

// Both solvers' options from the parsed arguments; false (the error printed)
// when a value is out of range.
bool MakeOptions(CompareArgs& a, CeresOptions* co, GaussNewtonOptions* go) {
  a.common.loop_closure_loss = ParseRobustLoss(a.robust);
  a.common.verbose = !a.quiet;
  *co = CeresOptions(a.common);
  co->sparse_library = ParseSparseLibrary(a.sparse);
  *go = GaussNewtonOptions(a.common);
  go->linear_solver = ParseCholeskyKind(a.linear_solver);
  go->damping = a.damping;
  go->reuse_factorization = !a.no_chord;
  go->factor_memory_bytes = ParseFactorMemory(a.factor_memory);
  std::string why;
  if (!co->IsValid(&why) || !go->IsValid(&why)) {
    PrintError(why);
    return false;
  }
  return true;
}

struct BothRuns {
  SolveResult ceres, gn;
  PoseGraph ceres_graph{2}, gn_graph{2};
};

// Each solver `repeat` times from `input`, alternating which goes first;
// each one's fastest run is kept.
BothRuns RunBoth(const PoseGraph& input, CeresOptions co, GaussNewtonOptions go, int repeat,
                 bool quiet) {
  BothRuns best{{}, {}, input, input};
  for (int round = 0; round < repeat; ++round) {
    // Progress lines for the first round only; the others are for timing.
    co.verbose = go.verbose = !quiet && round == 0;
    auto run_ceres = [&] {
      if (co.verbose) std::fprintf(stderr, "-- ceres --\n");
      PoseGraph graph = input;
      SolveResult r = SolveWithCeres(graph, co);
      if (round == 0 || r.time_s < best.ceres.time_s)
        best.ceres = std::move(r), best.ceres_graph = std::move(graph);
    };
    auto run_gn = [&] {
      if (go.verbose) std::fprintf(stderr, "-- gn (%s) --\n", ToString(go.linear_solver));
      PoseGraph graph = input;
      SolveResult r = SolveGaussNewton(graph, go);
      if (round == 0 || r.time_s < best.gn.time_s)
        best.gn = std::move(r), best.gn_graph = std::move(graph);
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
  return best;
}

void PrintTable(const SolveResult& c, const SolveResult& g, const PoseDifference& d,
                double chi2_rel) {
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
}

Json CompareJson(const std::string& path, InitMethod init_method, const InitReport& init_report,
                 const BothRuns& runs, const PoseDifference& d, double chi2_rel) {
  const SolveResult &c = runs.ceres, &g = runs.gn;
  Json j;
  j["file"] = path;
  Json init;
  init["method"] = ToString(init_method);
  PutNumber(init, "time_s", init_report.time_s);
  PutNumber(init, "chi2", init_report.chi2);
  if (init_method == InitMethod::kAuto) {
    init["chosen"] = ToString(init_report.chosen);
    PutNumber(init, "file_chi2", init_report.file_chi2);
    PutNumber(init, "chordal_chi2", init_report.chordal_chi2);  // null: its systems were singular
    init["robust_cost"] = init_report.robust_cost;  // the two above by the kernel's cost
  }
  j["init"] = std::move(init);
  j["ceres"] = SolverJson(c);
  j["gn"] = SolverJson(g);
  PutNumber(j, "max_translation_diff", d.max_translation);
  PutNumber(j, "rms_translation_diff", d.rms_translation);
  PutNumber(j, "max_rotation_diff_deg", d.max_rotation_deg);
  PutNumber(j, "rms_rotation_diff_deg", d.rms_rotation_deg);
  PutNumber(j, "final_chi2_relative_diff", chi2_rel);
  PutNumber(j, "time_ratio_gn_over_ceres", g.time_s / std::max(c.time_s, 1e-12));
  PutNumber(j, "gn_time_to_reach_ceres_s", TimeToReach(g, c.final_chi2));
  return j;
}

int RunCompare(int argc, char** argv) {
  CompareArgs a;
  ArgParser args(
      "compare FILE [--json OUT.json] [--tolerance M] [options]",
      "Optimises the graph twice from the estimate in the file: with Ceres\n"
      "(Levenberg-Marquardt, sparse normal Cholesky) and with cairn's own\n"
      "Gauss-Newton path on the same factors, manifolds and gauge. Prints both\n"
      "side by side, with the largest and RMS differences between the two\n"
      "solutions. Exits 1 when they differ by more than the tolerances.");
  DeclareOptions(args, a);
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (a.repeat < 1) {
    PrintError("--repeat must be at least 1");
    return 2;
  }
  CeresOptions co;
  GaussNewtonOptions go;
  if (!MakeOptions(a, &co, &go)) return 2;

  const InitMethod init_method = ParseInitMethod(a.init);
  CommandOutputs outputs;
  outputs.Input(a.path);
  outputs.Output(a.json);
  outputs.Check();
  PoseGraph input = ReadInputGraph(a.path);
  const InitReport init_report = Initialize(input, init_method, LossOfChi2(co.loop_closure_loss));
  if (!a.quiet)
    std::fprintf(stderr, "initial estimate: %s, %.4f s, chi2 %.10g\n", ToString(init_method),
                 init_report.time_s, init_report.chi2);
  const BothRuns runs = RunBoth(input, co, go, a.repeat, a.quiet);
  const SolveResult &c = runs.ceres, &g = runs.gn;
  const PoseDifference d = ComparePoses(runs.ceres_graph, runs.gn_graph);
  const double chi2_rel = std::abs(c.final_chi2 - g.final_chi2) / std::max(c.final_chi2, 1e-300);

  std::printf("%s: %zu vertices, %zu edges\n", a.path.c_str(), input.vertices().size(),
              input.edges().size());
  if (init_method == InitMethod::kAuto) std::printf("%s\n", DescribeAutoChoice(init_report).c_str());
  PrintTable(c, g, d, chi2_rel);
  if (!a.json.empty()) {
    Json j = CompareJson(a.path, init_method, init_report, runs, d, chi2_rel);
    PutRepairs(j, input);
    outputs.Write(a.json, [&](std::ostream& os) { os << DumpJson(j); });
    outputs.Commit();
  }
  // A problem the graph does not determine (solvers/determinacy.h) fails
  // both alike, before any step: say why rather than compare the starts.
  for (const SolveResult* r : {&c, &g})
    if (!r->usable) {
      PrintError(std::string(r == &c ? "ceres" : "gn") + " failed: " + r->message);
      return 1;
    }
  const bool agree = d.max_translation <= a.tol_m && d.max_rotation_deg <= a.tol_deg &&
                     chi2_rel <= a.tol_chi2;
  if (!agree) {
    std::printf("the solutions differ by more than the tolerances (%.3g m, %.3g deg, %.3g)\n",
                a.tol_m, a.tol_deg, a.tol_chi2);
    return 1;
  }
  std::printf("the solutions agree within %.3g m, %.3g deg and %.3g relative chi2\n", a.tol_m,
              a.tol_deg, a.tol_chi2);
  return 0;
}

}  // namespace

CAIRN_SOLVING_COMMAND("compare", "run the Ceres and Gauss-Newton paths side by side", RunCompare);

}  // namespace cairn::tools
