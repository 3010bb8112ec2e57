// cairn replay: a pose graph fed to the incremental optimizer pose by pose,
// timing each step, then solved exactly and against a batch solve.
#include <chrono>
#include <cstdio>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/runtime.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/incremental_replay.h"
#include "tools/args.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"
#include "tools/read_input.h"

namespace cairn::tools {
namespace {

struct ReplayArgs {
  std::string in, json, steps, solver = "gn";
  int every = 1;
  bool quiet = false, full = false;
  PartialUpdateOptions partial;
  double fill_bound = 0, relinearize_budget = 0;
};

void DeclarePartialOptions(ArgParser& args, ReplayArgs& a) {
  args.Option("relinearize-threshold", &a.partial.relinearize_threshold, "X",
              "gn: re-linearise a pose's edges once its step exceeds X (m, rad)");
  args.Option("wildfire-threshold", &a.partial.wildfire_threshold, "X",
              "gn: stop solving again below a step that changed by no more than X");
  args.Option("relinearize-budget", &a.relinearize_budget, "N",
              "gn: factor entries one update may spend re-linearising");
  args.Option("reserve-poses", &a.partial.reserve_poses, "N",
              "gn: poses the factor has room for before a fresh factorisation");
  args.Option("fill-bound", &a.fill_bound, "N",
              "gn: factor entries gained before a fresh ordering and factorisation");
  args.Option("fill-fraction", &a.partial.fill_fraction, "F",
              "gn: or this share of the factor's size, when that is more");
}

// One stderr line every few seconds: a 100,000-pose replay takes minutes.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet) {}
  void operator()(size_t fed, size_t total) {
    if (quiet_ || Seconds(last_) < 3) return;
    last_ = std::chrono::steady_clock::now();
    std::fprintf(stderr, "replay: %zu of %zu poses, %.1f s\n", fed, total, Seconds(start_));
  }

 private:
  bool quiet_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), last_ = start_;
};

Json ReplayJson(const ReplayArgs& a, const ReplayResult& r, double batch_chi2) {
  Json j;
  j["input"] = a.in;
  j["solver"] = a.solver;
  j["every"] = a.every;
  j["poses"] = r.poses;
  j["edges"] = r.edges;
  j["steps"] = r.step_s.size();
  PutNumber(j, "median_step_s", Percentile(r.step_s, 0.5));
  PutNumber(j, "p90_step_s", Percentile(r.step_s, 0.9));
  PutNumber(j, "p99_step_s", Percentile(r.step_s, 0.99));
  PutNumber(j, "max_step_s", Percentile(r.step_s, 1.0));
  PutNumber(j, "total_s", r.total_s);
  PutNumber(j, "median_step_cpu_s", Percentile(r.step_cpu_s, 0.5));
  PutNumber(j, "p99_step_cpu_s", Percentile(r.step_cpu_s, 0.99));
  double cpu = 0;
  for (double s : r.step_cpu_s) cpu += s;
  PutNumber(j, "total_cpu_s", cpu);
  PutNumber(j, "replay_chi2", r.replay_chi2);
  PutNumber(j, "final_chi2", r.final_chi2);
  PutNumber(j, "final_solve_s", r.final_time_s);
  PutNumber(j, "batch_chi2", batch_chi2);
  const ReplayResult::Counts c = r.Count();
  j["refactorizations"] = c.refactorizations;
  Json by;
  for (size_t k = 1; k < c.refactorizations_by.size(); ++k)
    by[ToString(static_cast<RebuildReason>(k))] = c.refactorizations_by[k];
  j["refactorizations_by_reason"] = by;
  PutNumber(j, "refactorization_steps_s", c.refactorization_steps_s);
  j["retried_steps"] = c.retried;
  j["whole_solves"] = c.whole_solves;
  j["relinearized_poses"] = c.relinearized;
  return j;
}

// One line a step: where the time went, for plots of step time against the
// graph's size.
void WriteSteps(std::ostream& os, const ReplayResult& r) {
  os << "step,poses,step_s,cpu_s,new_edges,relinearized_poses,solved_unknowns,"
        "fresh_factorization,retried\n";
  char line[256];
  for (size_t k = 0; k < r.step_s.size(); ++k) {
    const UpdateResult& u = r.step_updates[k];
    std::snprintf(line, sizeof line, "%zu,%zu,%.9f,%.9f,%d,%d,%d,%s,%d\n", k + 1, r.step_poses[k],
                  r.step_s[k], r.step_cpu_s[k], u.new_edges, u.relinearized_vertices,
                  u.solved_unknowns, u.refactorized ? ToString(u.reason) : "", u.retried);
    os << line;
  }
}

void PrintSummary(const ReplayArgs& a, const ReplayResult& r, double batch_chi2) {
  std::printf("%s: %zu poses, %zu edges, %zu steps (%s, every %d)\n", a.in.c_str(), r.poses,
              r.edges, r.step_s.size(), a.solver.c_str(), a.every);
  std::printf("step time: median %.3f ms, p90 %.3f ms, p99 %.3f ms, max %.3f ms\n",
              1e3 * Percentile(r.step_s, 0.5), 1e3 * Percentile(r.step_s, 0.9),
              1e3 * Percentile(r.step_s, 0.99), 1e3 * Percentile(r.step_s, 1.0));
  double cpu = 0;
  for (double s : r.step_cpu_s) cpu += s;
  std::printf("CPU time: median %.3f ms, p99 %.3f ms, total %.3f s\n",
              1e3 * Percentile(r.step_cpu_s, 0.5), 1e3 * Percentile(r.step_cpu_s, 0.99), cpu);
  std::printf("total %.3f s; chi2 after the last step %.10g\n", r.total_s, r.replay_chi2);
  if (a.solver == "gn" && !a.full) {
    const ReplayResult::Counts c = r.Count();
    std::printf("fresh factorisations %zu (%.3f s of steps; ", c.refactorizations,
                c.refactorization_steps_s);
    for (size_t k = 1; k < c.refactorizations_by.size(); ++k)
      std::printf("%s%s %zu", k > 1 ? ", " : "", ToString(static_cast<RebuildReason>(k)),
                  c.refactorizations_by[k]);
    std::printf("), refused steps taken again %zu, whole solves %zu, poses re-linearised %zu\n",
                c.retried, c.whole_solves, c.relinearized);
  }
  const double rel = batch_chi2 != 0 ? (r.final_chi2 - batch_chi2) / batch_chi2 : 0;
  std::printf("final chi2 %.10g (exact solve %.3f s), batch %.10g, relative difference %.3g\n",
              r.final_chi2, r.final_time_s, batch_chi2, rel);
}

int RunReplay(int argc, char** argv) {
  ReplayArgs a;
  ArgParser args(
      "replay FILE.g2o [--every N] [--solver ceres|gn] [--json FILE]",
      "Feeds a pose graph to the incremental optimizer as a robot would have built\n"
      "it: poses in id order, each with its estimate from an older pose and its\n"
      "measurement (odometry first), its edges to poses already there (odometry, the\n"
      "loop closures whose both ends exist, priors), and an update after each pose\n"
      "(or every N). Prints the per-step wall time (median, p90, p99, max) and CPU\n"
      "time (what a step costs on a machine shared with other jobs), the\n"
      "total, and the chi2 after a final exact optimisation against a batch solve\n"
      "of the file from its own estimate with the same solver. Progress on stderr.");
  args.Positional("FILE", &a.in, "the graph (g2o or TORO)");
  args.Option("every", &a.every, "N", "poses fed between updates");
  args.Option("solver", &a.solver, "NAME", "gn (Gauss-Newton) or ceres");
  args.Option("json", &a.json, "FILE", "also write the figures as JSON (keys steps, "
              "median_step_s, p90_step_s, p99_step_s, max_step_s, total_s, final_chi2, batch_chi2; "
              "the steps' process CPU time too)");
  args.Option("steps", &a.steps, "FILE.csv", "also write one line a step (poses fed, wall and "
              "CPU seconds, new edges, poses re-linearised, unknowns solved, why a fresh "
              "factorisation was made, a refused step taken again)");
  args.Flag("full", &a.full, "gn: re-solve the whole graph at each step (Optimize) rather "
            "than update it partially");
  args.Flag("quiet", &a.quiet, "no progress lines");
  a.fill_bound = static_cast<double>(a.partial.fill_bound);
  a.relinearize_budget = static_cast<double>(a.partial.relinearize_budget);
  DeclarePartialOptions(args, a);
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  a.partial.fill_bound = static_cast<long>(a.fill_bound);
  a.partial.relinearize_budget = static_cast<long>(a.relinearize_budget);
  std::string why;
  if (!a.partial.IsValid(&why)) {
    PrintError(why);
    return 2;
  }
  SolverKind kind;
  try {
    kind = ParseSolverKind(a.solver);
  } catch (const std::exception& e) {
    PrintError(e.what());
    return 2;
  }
  if (a.every < 1) {
    PrintError("--every must be at least 1");
    return 2;
  }
  CommandOutputs outputs;
  outputs.Input(a.in);
  outputs.Output(a.json);
  outputs.Output(a.steps, ".csv");
  outputs.Check();

  PoseGraph graph = ReadInputGraph(a.in);
  RequireNoLandmarks(graph, "cairn replay");
  ReplayOptions o;
  o.every = a.every;
  o.incremental.partial = a.partial;
  o.mode = kind == SolverKind::kCeres ? ReplayMode::kCeres
          : a.full        ? ReplayMode::kGaussNewton
                          : ReplayMode::kPartial;
  Progress progress(a.quiet);
  o.progress = [&](size_t fed, size_t total) { progress(fed, total); };
  const ReplayResult r = Replay(graph, o);
  const SolveResult batch =
      kind == SolverKind::kCeres ? SolveWithCeres(graph) : SolveGaussNewton(graph);
  PrintSummary(a, r, batch.final_chi2);
  if (!a.json.empty()) {
    const std::string text = DumpJson(ReplayJson(a, r, batch.final_chi2));
    outputs.Write(a.json, [&](std::ostream& os) { os << text; });
  }
  if (!a.steps.empty()) outputs.Write(a.steps, [&](std::ostream& os) { WriteSteps(os, r); });
  outputs.Commit();
  return 0;
}

}  // namespace

CAIRN_SOLVING_COMMAND("replay", "feed a graph pose by pose to the incremental optimizer, time it",
                      RunReplay);

}  // namespace cairn::tools
