// cairn optimize: read a pose graph, optimise it, write it as g2o.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/graph/chi2.h"
#include "cairn/solvers/covariance.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/graph/initialization.h"
#include "cairn/robust/kernel_warm_start.h"
#include "cairn/robust/outliers.h"
#include "cairn/solvers/solve_result.h"
#include "cairn/graph/svg_plot.h"
#include "tools/args.h"
#include "tools/read_input.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// What the command line says, before it is turned into the solvers' options.
struct OptimizeArgs {
  std::string in, out, solver = "ceres", robust = "none", method = "lm", sparse = "auto";
  std::string init, report, plot, linear_solver = "auto", covariance_ids, rejected;
  bool quiet = false, strict = false;
  SolverOptions common;
  // Ceres's own settings and Gauss-Newton's, at their defaults.
  double initial_radius = CeresOptions().initial_trust_region_radius;
  double min_lm_diagonal = CeresOptions().min_lm_diagonal;
  bool postordering = false, no_jacobi = false;
  double gn_damping = GaussNewtonOptions().damping;
  bool gn_no_chord = false;
  std::string gn_factor_memory = "auto";
  bool reject_outliers = false, no_readmit = false, no_verify = false, no_final = false;
  bool no_scaling = false;
  OutlierRejectionOptions rejection;
  bool no_kernel_warm_start = false;
  KernelWarmStartOptions warm_start;
};

void DeclareSolverOptions(ArgParser& args, OptimizeArgs& a) {
  args.Option("solver", &a.solver, "NAME",
              "ceres (Ceres's trust-region solver) or gn (cairn's own Gauss-Newton, "
              "damped only when a step fails)");
  args.Option("method", &a.method, "lm|dogleg",
              "ceres: Levenberg-Marquardt or Powell's dogleg trust region");
  args.Option("sparse", &a.sparse, "LIB",
              "ceres: sparse Cholesky library: auto (suitesparse, see docs/benchmarks.md), "
              "suitesparse (CHOLMOD), eigen (simplicial LDLT), cxsparse");
  args.Option("max-iterations", &a.common.max_iterations, "N", "stop after N iterations");
  args.Option("robust", &a.robust, "KIND:DELTA",
              "robust loss on loop closures: none, huber:DELTA, cauchy:DELTA (DELTA on the "
              "whitened error, as g2o's kernels) or dcs:PHI (dynamic covariance scaling, PHI "
              "on chi2)");
  args.Flag("no-kernel-warm-start", &a.no_kernel_warm_start,
            "with --robust: one plain solve, without warm-up rounds that leave out the loop "
            "closures the kernel weighs below --kernel-min-weight");
  args.Option("kernel-min-weight", &a.warm_start.min_weight, "W",
              "with --robust: warm-up rounds leave out loop closures weighed below W (1e-6), "
              "then the whole graph is solved from there");
  args.Option("threads", &a.common.threads, "N", "threads for linearisation (0: one per core)");
  args.Option("function-tolerance", &a.common.function_tolerance, "TOL",
              "stop when one step lowers chi2 by less than this fraction");
  args.Option("gradient-tolerance", &a.common.gradient_tolerance, "TOL",
              "stop when the largest gradient component is below this times chi2 per residual");
  args.Option("parameter-tolerance", &a.common.parameter_tolerance, "TOL",
              "stop when the step is this small relative to the estimate");
  args.Option("initial-radius", &a.initial_radius, "R",
              "ceres: first trust-region radius (large: start close to Gauss-Newton)");
  args.Option("min-lm-diagonal", &a.min_lm_diagonal, "D",
              "ceres: lower bound on Levenberg-Marquardt's diagonal damping (times the "
              "largest information entry when that is below 1)");
  args.Flag("postordering", &a.postordering,
            "ceres: let the sparse Cholesky order the normal matrix itself (AMD with "
            "postordering) instead of pre-permuting the Jacobian");
  args.Flag("no-jacobi-scaling", &a.no_jacobi, "ceres: do not scale columns of the Jacobian");
  args.Option("linear-solver", &a.linear_solver, "NAME",
              "how H dx = -b is solved. gn: auto, parallel, supernodal, simplicial, cholmod-auto, "
              "eigen (Cholesky), qr (sparse QR of the whitened Jacobian, never forming H), cg "
              "(conjugate gradients, preconditioned by a spanning tree and the most strongly "
              "coupled other blocks, within four times H's size) or cg-jacobi (block-Jacobi); "
              "ceres: auto (sparse Cholesky), qr (dense QR, small graphs) or cg (CGNR)");
  args.Flag("gn-no-chord", &a.gn_no_chord,
            "gn: factorise at every step (no steps with an earlier factorisation)");
  args.Option("gn-factor-memory", &a.gn_factor_memory, "MB",
              "gn: the most the two-halves factorisation's factors may hold in memory; beyond "
              "it one half's waits on disk ($TMPDIR, else /var/tmp) while the other works, on "
              "one core, with the same result: auto (about 1.5 KB an edge, at least 256 MiB), "
              "unlimited or a number of MB");
  args.Option("gn-damping", &a.gn_damping, "LAMBDA",
              "gn: Levenberg-Marquardt damping (times diag H) the fallback starts from, 1/radius as in Ceres");
}

void DeclareOutlierOptions(ArgParser& args, OptimizeArgs& a) {
  OutlierRejectionOptions& r = a.rejection;
  args.Flag("reject-outliers", &a.reject_outliers,
            "decide which loop closures are wrong (pairwise consistency, then graduated "
            "non-convexity on truncated least squares) and drop them: -o holds the kept "
            "graph, the report lists them as rejected_loop_closures");
  args.Option("outlier-threshold", &r.threshold_chi2, "CHI2",
              "with --reject-outliers: the chi2 above which a loop closure is wrong (0: the "
              "--outlier-confidence quantile for 3 or 6 dof)");
  args.Option("outlier-confidence", &r.confidence, "P",
              "with --reject-outliers: quantile of chi2 taken as the threshold");
  args.Option("gnc-iterations", &r.inner_iterations, "N",
              "with --reject-outliers: iterations of each weighted solve inside GNC (0: "
              "--max-iterations); the solves without the rejected ones run in full");
  args.Option("gnc-tolerance", &r.inner_tolerance, "TOL",
              "with --reject-outliers: each weighted solve inside GNC stops once a step lowers "
              "chi2 (or the gradient) by less than this fraction (0: --function-tolerance and "
              "--gradient-tolerance)");
  args.Option("gnc-mu-factor", &r.mu_factor, "F",
              "with --reject-outliers: GNC's mu grows by this factor from one weighted solve "
              "to the next (larger: fewer solves, a coarser path to the truncated cost)");
  args.Option("outlier-window", &r.consistency_window, "N",
              "with --reject-outliers: the largest pairwise consistent set of loop closures "
              "(every pair whose ends lie within N ids tested, and random others), less "
              "those no neighbour agrees with, goes through GNC first, alone (0: no such "
              "stage)");
  args.Option("outlier-restart", &r.restart_chi2_factor, "F",
              "with --reject-outliers: GNC starts with the loop closures beyond F times the "
              "threshold at weight 0 (on the trusted ones, beyond F times the plain "
              "threshold; over all of them, F times the threshold tightened by the variance "
              "factor)");
  args.Flag("no-outlier-readmission", &a.no_readmit,
            "with --reject-outliers: do not take back rejected loop closures whose "
            "innovation statistic at the final estimate is within the threshold");
  args.Option("rejected", &a.rejected, "FILE.g2o",
              "with --reject-outliers: write the rejected loop closures there (with their "
              "poses at the final estimate); -o holds only the kept ones");
  args.Option("outlier-partners", &r.consistency_partners, "N",
              "with --reject-outliers: random loop closures each one's consistency is tested "
              "against, besides those within --outlier-window ids");
  args.Flag("no-outlier-variance-scaling", &a.no_scaling,
            "with --reject-outliers: keep the consistency tests' and GNC's thresholds as "
            "they are, whatever noise the data show");
  args.Flag("no-outlier-final-solve", &a.no_final,
            "with --reject-outliers: skip the kept graph's last solves in full (from the "
            "estimate reached and from a fresh start)");
  args.Option("outlier-run-window", &r.group_window, "N",
              "with --reject-outliers: the verification also tests runs of kept loop "
              "closures (both ends within N ids of another's) as a whole, and rejects a run "
              "whose deletion would lower chi2 by more than its size times the threshold "
              "(0: no such test)");
  args.Flag("no-outlier-verification", &a.no_verify,
            "with --reject-outliers: skip the check after GNC (kept loop closures whose "
            "deletion would lower chi2 by more than the threshold are rejected too)");
}

void DeclareOptions(ArgParser& args, OptimizeArgs& a) {
  args.Positional("IN", &a.in, "a .g2o or TORO .graph file");
  args.Option("output", &a.out, "OUT.g2o", "where to write the optimised graph (g2o; TORO if *.graph)");
  args.Alias("-o", "output");
  DeclareSolverOptions(args, a);
  args.Option("report", &a.report, "FILE.json",
              "write a JSON report: initial_chi2, final_chi2, iterations, time_s, "
              "termination, timings, the per-iteration trace, repaired_information");
  args.Option("covariance", &a.covariance_ids, "IDS",
              "print the marginal covariances (tangent space, the pose's own frame; a "
              "landmark's in the world frame) of these vertices at the optimum, e.g. 3,17,42, "
              "and add them to the --report JSON");
  args.Option("plot", &a.plot, "FILE.svg",
              "draw the trajectory before and after, loop closures in red (3D: x-y view)");
  DeclareOutlierOptions(args, a);
  args.Option("init", &a.init, "METHOD",
              "initial estimate: auto (the default: the file's vertices, or the chordal "
              "relaxation when its chi2 is lower; with --reject-outliers the default is file, "
              "since wrong loop closures bend the relaxation), file (the file's vertices), odometry "
              "(chained odometry), spanning-tree (chained along the most certain edges) or "
              "chordal (chordal relaxation of the rotations, then linear translations)");
  args.Flag("quiet", &a.quiet, "no progress lines and no summary");
  args.Flag("strict", &a.strict, "accepted for old scripts: unknown tags are always refused now "
                                 "(unless --keep-unknown)");
}

// Everything the solve needs, checked before the input is read.
struct OptimizePlan {
  SolverKind solver = SolverKind::kCeres;
  CeresOptions ceres;
  GaussNewtonOptions gn;
  InitMethod init = InitMethod::kFile;
  std::vector<int64_t> covariance_of;
};

// The arguments made into options and checked (the libraries' own IsValid);
// false, the error printed, when one is bad.
bool MakePlan(OptimizeArgs& a, OptimizePlan* p) {
  if (a.out.empty()) {
    PrintError("optimize needs an output file (-o OUT.g2o)");
    return false;
  }
  try {
    p->solver = ParseSolverKind(a.solver);
    a.common.loop_closure_loss = ParseRobustLoss(a.robust);
    a.common.verbose = !a.quiet;
    p->ceres = CeresOptions(a.common);
    p->ceres.method = ParseCeresMethod(a.method);
    p->ceres.sparse_library = ParseSparseLibrary(a.sparse);
    p->ceres.initial_trust_region_radius = a.initial_radius;
    p->ceres.min_lm_diagonal = a.min_lm_diagonal;
    p->ceres.use_postordering = a.postordering;
    p->ceres.jacobi_scaling = !a.no_jacobi;
    p->gn = GaussNewtonOptions(a.common);
    // The names differ between the paths ("auto" means each one's default).
    if (p->solver == SolverKind::kCeres)
      p->ceres.linear_solver = ParseCeresLinearSolver(a.linear_solver);
    else
      p->gn.linear_solver = ParseCholeskyKind(a.linear_solver);
    p->gn.damping = a.gn_damping;
    p->gn.reuse_factorization = !a.gn_no_chord;
    p->gn.factor_memory_bytes = ParseFactorMemory(a.gn_factor_memory);
    // Outlier rejection trusts its start, and the chordal relaxation takes in
    // every loop closure, wrong ones included.
    p->init = ParseInitMethod(!a.init.empty() ? a.init : a.reject_outliers ? "file" : "auto");
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return false;
  }
  try {
    if (!a.covariance_ids.empty()) p->covariance_of = ParseIdList(a.covariance_ids);
  } catch (const std::invalid_argument& e) {
    PrintError(std::string("--covariance: ") + e.what());
    return false;
  }
  if (!a.rejected.empty() && !a.reject_outliers) {
    PrintError("--rejected needs --reject-outliers");
    return false;
  }
  // The kept graph's last solve restarts from --init when it is given; else
  // from the better of the file's vertices and the chordal relaxation, which
  // no wrong loop closure bends any more.
  a.rejection.fresh_init = !a.init.empty() ? p->init : InitMethod::kAuto;
  a.rejection.verify = !a.no_verify;
  a.rejection.final_solve = !a.no_final;
  a.rejection.scale_by_variance = !a.no_scaling;
  a.rejection.readmit = !a.no_readmit;
  // The inner solves are many: one progress line per GNC round instead.
  a.rejection.verbose = !a.quiet;
  a.rejection.threads = a.common.threads;
  std::string why;
  if (!p->ceres.IsValid(&why) || !p->gn.IsValid(&why) ||
      (a.reject_outliers && !a.rejection.IsValid(&why)) || !a.warm_start.IsValid(&why)) {
    PrintError(why);
    return false;
  }
  return true;
}

SolveResult Solve(PoseGraph& graph, const OptimizePlan& p) {
  return p.solver == SolverKind::kGaussNewton ? SolveGaussNewton(graph, p.gn)
                                              : SolveWithCeres(graph, p.ceres);
}

// The main solve without --reject-outliers: with a kernel, warm-started
// without the loop closures it weighs at nearly nothing (their fill-in, not
// their weight, is what a corrupted graph's iterations cost).
SolveResult SolveMain(PoseGraph& graph, const OptimizeArgs& a, const OptimizePlan& p) {
  if (a.no_kernel_warm_start || a.common.loop_closure_loss.kind == RobustLoss::kNone)
    return Solve(graph, p);
  KernelWarmStartOptions o = a.warm_start;
  o.verbose = !a.quiet;
  return SolveKernelWarmStarted(
      graph, a.common.loop_closure_loss,
      [&](PoseGraph& g, const InnerSolve&) { return Solve(g, p); }, o);
}

// The rejection with the chosen solver inside; *rejected gets the pairs
// found wrong and `graph` becomes the kept graph (its estimate the last
// solve's). The result is the whole run's: the input's chi2, the kept
// graph's, the iterations of every inner solve and the run's wall time.
SolveResult SolveRejecting(PoseGraph& graph, const OptimizeArgs& a, const OptimizePlan& p,
                           std::vector<VertexPair>* rejected, PoseGraph* rejected_graph) {
  const auto start = std::chrono::steady_clock::now();
  OptimizePlan inner = p;
  inner.ceres.verbose = inner.gn.verbose = false;
  const OutlierRejectionResult r = SolveRejectingOutliers(
      graph,
      [&](PoseGraph& g, const InnerSolve& limits) {
        OptimizePlan q = inner;
        if (limits.max_iterations > 0)
          q.ceres.max_iterations = q.gn.max_iterations = limits.max_iterations;
        if (limits.tolerance > 0) {
          q.ceres.function_tolerance = q.gn.function_tolerance = limits.tolerance;
          q.ceres.gradient_tolerance = q.gn.gradient_tolerance = limits.tolerance;
        }
        return Solve(g, q);
      },
      a.rejection);
  *rejected = r.rejected;
  *rejected_graph = PoseGraph(graph.dimension());
  for (size_t k : r.rejected_edges) {
    const Edge& e = graph.edges()[k];
    for (int64_t id : {e.from, e.to})
      if (!rejected_graph->HasVertex(id))
        rejected_graph->AddVertex(id, graph.vertex(id).x, graph.vertex(id).fixed);
    rejected_graph->AddEdge(e);
  }
  const size_t closures = graph.CountEdges(EdgeKind::kLoopClosure);
  graph = WithoutEdges(graph, r.rejected_edges);
  SolveResult result = r.solve;
  result.iterations = r.iterations;
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!a.quiet)
    std::fprintf(stderr,
                 "%s: rejected %zu of %zu loop closures (%d of them by verification; chi2 "
                 "threshold %.4g; %d solves, %d iterations, %.3f s in the solves)\n",
                 a.in.c_str(), rejected->size(), closures, r.verified, r.threshold_chi2,
                 r.rounds, r.iterations, r.solve_time_s);
  return result;
}

// From the solver that found the optimum (Ceres's ceres::Covariance, or the
// Gauss-Newton factorisation; tests/test_covariance.cpp checks that the two
// agree), printed.
std::vector<Eigen::MatrixXd> Covariances(const PoseGraph& graph, const OptimizePlan& p) {
  const std::vector<Eigen::MatrixXd> covariances =
      MarginalCovariances(graph, p.covariance_of, p.solver, p.ceres.loop_closure_loss);
  for (size_t k = 0; k < p.covariance_of.size(); ++k) {
    const bool point = graph.vertex(p.covariance_of[k]).landmark;
    const bool planar = graph.dimension() == 2;
    std::printf("vertex %lld covariance (%s)%s:\n", static_cast<long long>(p.covariance_of[k]),
                point ? (planar ? "landmark x y" : "landmark x y z")
                      : (planar ? "dx dy dtheta, own frame" : "dx dy dz wx wy wz, own frame"),
                covariances[k].isZero() ? " [held: the gauge or fixed]" : "");
    for (int i = 0; i < covariances[k].rows(); ++i) {
      for (int j = 0; j < covariances[k].cols(); ++j) std::printf(" %14.6e", covariances[k](i, j));
      std::printf("\n");
    }
  }
  return covariances;
}

struct Timings {
  double read_s = 0;
  InitReport init;
};

// The library's report with the command's context, the rejected loop
// closures first and the covariances last.
std::string ReportJson(const OptimizeArgs& a, const OptimizePlan& p, const PoseGraph& graph,
                 const SolveResult& result, const Timings& t,
                 const std::vector<VertexPair>& rejected, size_t input_closures,
                 const std::vector<Eigen::MatrixXd>& covariances) {
  const bool gn = p.solver == SolverKind::kGaussNewton;
  std::vector<std::pair<std::string, std::string>> context = {
      {"input", a.in},
      {"output", a.out},
      {"dimension", std::to_string(graph.dimension())},
      {"vertices", std::to_string(graph.vertices().size())},
      {"landmarks", std::to_string(graph.CountLandmarks())},
      {"edges", std::to_string(graph.edges().size())},
      {"loop_closures", std::to_string(graph.CountEdges(EdgeKind::kLoopClosure))},
      {"robust", ToString(p.ceres.loop_closure_loss)},
      {"method", gn ? "gauss-newton" : a.method},
      {"sparse", gn ? a.linear_solver : a.sparse},
      {"read_time_s", Number(t.read_s)},
      {"init", ToString(p.init)},
      {"init_time_s", Number(t.init.time_s)},
      {"init_chi2", Number(t.init.chi2)},
  };
  if (p.init == InitMethod::kAuto) {
    context.emplace_back("init_chosen", ToString(t.init.chosen));
    context.emplace_back("init_file_chi2", Number(t.init.file_chi2));
    context.emplace_back("init_chordal_chi2", Number(t.init.chordal_chi2));
  }
  std::ostringstream text;
  WriteReportJson(result, text, context);
  Json report = Json::parse(text.str());
  // With --robust, init_file_chi2 and init_chordal_chi2 are the kernel's
  // costs (InitializeAuto).
  if (p.init == InitMethod::kAuto) report["init_robust_cost"] = t.init.robust_cost;
  // File names are text, whatever they look like.
  report["input"] = a.in;
  report["output"] = a.out;
  Json j = Json::object();
  if (a.reject_outliers) {
    j["rejected_loop_closures"] = Json::array();
    for (const VertexPair& pair : rejected)
      j["rejected_loop_closures"].push_back({pair.first, pair.second});
    // The sizes below are the kept graph's, as written to -o.
    j["input_loop_closures"] = input_closures;
  }
  for (auto& [key, value] : report.items()) j[key] = std::move(value);
  PutRepairs(j, graph);  // the counts of --repair-information, 0 without
  if (!covariances.empty()) {
    Json cov = Json::object();
    for (size_t k = 0; k < p.covariance_of.size(); ++k)
      PutMatrix(cov, std::to_string(p.covariance_of[k]), covariances[k]);
    j["covariance"] = std::move(cov);
  }
  return DumpJson(j);
}

// Every path checked before the input is read: a bad --report must not
// cost a solve, and must leave -o as it was.
void DeclareFiles(const OptimizeArgs& a, CommandOutputs& outputs) {
  outputs.Input(a.in);
  outputs.GraphOutput(a.out);
  outputs.Output(a.report);
  outputs.Output(a.plot, ".svg");
  outputs.GraphOutput(a.rejected);
  outputs.Check();
}

int RunOptimize(int argc, char** argv) {
  OptimizeArgs a;
  ArgParser args(
      "optimize IN -o OUT.g2o [--solver ceres|gn] [--robust huber:D|cauchy:D|dcs:PHI] [options]",
      "Optimises a g2o or TORO pose graph from the estimate in the file and writes the\n"
      "result as g2o, or as TORO when OUT ends in .graph (to a temporary file, renamed\n"
      "when complete). Vertices marked\n"
      "FIX stay put; when none is and no prior anchors the graph, the lowest-id\n"
      "vertex is held (when position-only priors fix only its position, the\n"
      "rotation of the lowest prior vertex). A graph that singular information\n"
      "leaves undetermined is refused, naming the vertex and the free direction;\n"
      "an indefinite information matrix is refused unless --repair-information.\n"
      "Progress goes to stderr, one line per iteration (chi2 is\n"
      "g2o's: twice Ceres's cost, robustified when --robust is set). Options marked\n"
      "ceres: or gn: apply to that solver only.");
  DeclareOptions(args, a);
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  OptimizePlan p;
  if (!MakePlan(a, &p)) return 2;

  CommandOutputs outputs;
  DeclareFiles(a, outputs);

  Timings t;
  const auto read_start = std::chrono::steady_clock::now();
  PoseGraph graph = ReadInputGraph(a.in);
  t.read_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
  outputs.CheckGraphFits(graph);
  // Only copied when asked for: the "before" panel of the plot, the file's
  // own estimate whatever the initialisation.
  const PoseGraph before = a.plot.empty() ? PoseGraph(graph.dimension()) : graph;
  t.init = Initialize(graph, p.init, LossOfChi2(a.common.loop_closure_loss));
  if (!a.quiet && p.init != InitMethod::kFile)
    std::fprintf(stderr, "initial estimate: %s, %.4f s, chi2 %.10g\n", ToString(p.init),
                 t.init.time_s, t.init.chi2);
  if (!a.quiet && p.init == InitMethod::kAuto)
    std::printf("%s\n", DescribeAutoChoice(t.init).c_str());

  std::vector<VertexPair> rejected;
  PoseGraph rejected_graph(graph.dimension());
  const size_t input_closures = graph.CountEdges(EdgeKind::kLoopClosure);
  const SolveResult result = a.reject_outliers
                                 ? SolveRejecting(graph, a, p, &rejected, &rejected_graph)
                                 : SolveMain(graph, a, p);
  std::vector<Eigen::MatrixXd> covariances;
  // Not from a failed solve: the estimate is no optimum.
  if (!p.covariance_of.empty() && result.usable) {
    try {
      covariances = Covariances(graph, p);
    } catch (const std::exception& e) {
      PrintError(std::string("--covariance: ") + e.what());
      return 1;
    }
  }
  // A failed solve leaves -o as it was (the report still says why); the
  // rest go in place together or not at all.
  if (result.usable) outputs.WriteGraph(a.out, graph);
  if (result.usable && !a.rejected.empty()) outputs.WriteGraph(a.rejected, rejected_graph);
  if (!a.report.empty()) {
    const std::string json =
        ReportJson(a, p, graph, result, t, rejected, input_closures, covariances);
    outputs.Write(a.report, [&](std::ostream& os) { os << json; });
  }
  if (!a.plot.empty()) {
    PlotPanel pa{&before, "before: chi2 " + Number(Chi2(before)), "#888888"};
    PlotPanel pb{&graph, "after: chi2 " + Number(result.final_chi2)};
    outputs.Write(a.plot, [&](std::ostream& os) { WriteSvgPlot(os, {pa, pb}, a.in); });
  }
  outputs.Commit();
  if (!a.quiet) {
    std::fprintf(stderr, "%s: chi2 %.10g -> %.10g, %d iterations, %.3f s (%s)\n", a.in.c_str(),
                 result.initial_chi2, result.final_chi2, result.iterations, result.time_s,
                 result.termination.c_str());
  }
  if (!result.usable) {
    PrintError("the solver failed, " + a.out + " not written: " + result.message);
    return 1;
  }
  return 0;
}

}  // namespace

CAIRN_SOLVING_COMMAND("optimize", "optimise a pose graph (Ceres or Gauss-Newton), write it as g2o",
              RunOptimize);

}  // namespace cairn::tools
