// `cairn eval EST REF`: trajectory errors between an estimate and a reference.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cairn/frontend/relations.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"
#include "tools/args.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

constexpr const char* kDescription =
    "Absolute trajectory error (ATE: RMSE of the positions of EST, aligned onto REF,\n"
    "against REF's) and relative pose error (RPE) over segments of reference path, as\n"
    "evo and the TUM benchmark define them. In the plane when both files are planar,\n"
    "in 3D (z, roll and pitch count) when either is not; a planar file against a 3D\n"
    "one is taken at z = 0 with no roll or pitch, and the output says so.\n"
    "Each file is TUM text ('timestamp tx ty tz qx qy qz qw', '#' comment lines;\n"
    "planar when every z, qx and qy is 0 to 1e-9), a g2o graph (VERTEX_SE2 or\n"
    "VERTEX_SE3:QUAT poses, landmarks left out; a 3D graph is 3D) or a CARMEN log (the\n"
    "poses on its laser lines). Pairing: two CARMEN logs by scan; a g2o graph has no\n"
    "times, so vertex k pairs with vertex k of another graph or the k-th pose of a\n"
    "timed file (e.g. 'cairn map' numbers keyframes as PREFIX_trajectory.tum lists them); otherwise each pose\n"
    "pairs with the nearest stamp within --max-dt, closest pairs first, each pose used\n"
    "once (poses that share a stamp pair in order with as many at the nearest stamp,\n"
    "and are left out otherwise). Unpaired poses are counted and warned about.\n"
    "--align: none (as they are), se3 (the least-squares rotation and translation,\n"
    "Umeyama; planar in 2D), sim3 (and a scale, reported; RPE then uses the scaled\n"
    "estimate, as evo's --correct_scale does).\n"
    "--json fields: ate_rmse (m), rpe_trans_rmse (m), rpe_rot_rmse_deg, matched (poses\n"
    "paired), unpaired_est, unpaired_ref, pairing ('stamp', 'vertex id', 'scan index'),\n"
    "max_dt (s), dimension (2 or 3), est_dimension, ref_dimension, align, scale,\n"
    "segment (m), rpe_pairs (segments), and evo's statistics (rmse, mean, median, std,\n"
    "min, max, count) of each error: ate (|t_ref - t_est'|, est' the aligned EST, m),\n"
    "ate_rot_deg (angle of R_ref^-1 R_est'), rpe_trans (|t| of E = (ref_i^-1 ref_j)^-1\n"
    "(est_i^-1 est_j) over each segment i->j, m) and rpe_rot_deg (angle of E).\n"
    "--relations FILE (no REF): the metric of Kuemmerle et al. 2009 instead. FILE's\n"
    "lines 't1 t2 x y z roll pitch yaw' are reference displacements between the poses\n"
    "at t1 and t2; each end pairs with EST's pose at the nearest stamp within --max-dt\n"
    "(--by-scan: t1, t2 are 0-based scan indices, for EST files that know them, as\n"
    "cairn map's CSV files do). Reported: mean and standard deviation of the\n"
    "translational (m) and rotational (deg) errors |t(E)| and angle(E), E =\n"
    "delta_ref^-1 delta_est, and of their squares; relations with an end unpaired\n"
    "(or whose nearest stamp several poses share) are counted and warned about.\n"
    "JSON: relations, used, unpaired, pairing, dimension, and evo's statistics of\n"
    "trans (m), rot_deg, trans_sq (m^2), rot_sq_deg2 (deg^2).";

struct EvalArgs {
  std::string est_path, ref_path, json_path, align = "se3", relations_path;
  bool by_scan = false;
  frontend::EvalOptions options;
};

void PutStats(Json& j, const std::string& key, const frontend::ErrorStats& s) {
  Json o;
  PutNumber(o, "rmse", s.rmse);
  PutNumber(o, "mean", s.mean);
  PutNumber(o, "median", s.median);
  PutNumber(o, "std", s.std);
  PutNumber(o, "min", s.min);
  PutNumber(o, "max", s.max);
  o["count"] = s.count;
  j[key] = o;
}

Json ToJson(const EvalArgs& a, const frontend::Trajectory& est, const frontend::Trajectory& ref,
            const frontend::TrajectoryErrors& e) {
  Json j;
  PutNumber(j, "ate_rmse", e.ate_rmse);
  PutNumber(j, "rpe_trans_rmse", e.rpe_trans_rmse);
  PutNumber(j, "rpe_rot_rmse_deg", e.rpe_rot_rmse_deg);
  j["matched"] = e.matched;
  j["unpaired_est"] = e.unpaired_est;
  j["unpaired_ref"] = e.unpaired_ref;
  j["pairing"] = frontend::PairingName(e.pairing);
  PutNumber(j, "max_dt", a.options.max_dt);
  j["dimension"] = e.dimension;
  j["est_dimension"] = est.dimension;
  j["ref_dimension"] = ref.dimension;
  j["align"] = frontend::AlignmentName(a.options.align);
  PutNumber(j, "scale", e.scale);
  PutNumber(j, "segment", a.options.segment);
  j["rpe_pairs"] = e.rpe_pairs;
  PutStats(j, "ate", e.ate);
  PutStats(j, "ate_rot_deg", e.ate_rot_deg);
  PutStats(j, "rpe_trans", e.rpe_trans);
  PutStats(j, "rpe_rot_deg", e.rpe_rot_deg);
  return j;
}

std::string PairingText(const EvalArgs& a, frontend::Pairing p) {
  std::ostringstream os;
  os << "by " << frontend::PairingName(p);
  if (p == frontend::Pairing::kStamp) os << " within " << a.options.max_dt << " s";
  return os.str();
}

void PrintReport(const EvalArgs& a, const frontend::Trajectory& est, const frontend::Trajectory& ref,
                 const frontend::TrajectoryErrors& e) {
  std::cout << std::setprecision(6) << "matched " << e.matched << " of " << est.size() << " poses ("
            << PairingText(a, e.pairing) << "; " << e.unpaired_ref << " of " << ref.size()
            << " reference poses unpaired)\n"
            << "evaluated in " << e.dimension << "D, alignment " << frontend::AlignmentName(a.options.align);
  if (a.options.align == frontend::Alignment::kSimilarity) std::cout << ", scale " << e.scale;
  std::cout << "\n";
  for (const auto& [t, path] : {std::pair{&est, a.est_path}, std::pair{&ref, a.ref_path}})
    if (t->dimension < e.dimension)
      std::cout << path << " is planar: taken at z = 0 with no roll or pitch\n";
  std::cout << "ATE RMSE " << e.ate_rmse << " m (mean " << e.ate.mean << ", median " << e.ate.median
            << ", max " << e.ate.max << "), rotation " << e.ate_rot_deg.rmse << " deg\n"
            << "RPE RMSE (" << a.options.segment << " m) " << e.rpe_trans_rmse << " m, "
            << e.rpe_rot_rmse_deg << " deg over " << e.rpe_pairs << " segments\n";
}

// `--relations FILE EST`: the benchmark's relative errors, no alignment.
int RunRelations(const EvalArgs& a, CommandOutputs& outputs) {
  const frontend::Trajectory est = frontend::ReadTrajectory(a.est_path);
  const std::vector<frontend::Relation> rel = frontend::ReadRelations(a.relations_path);
  const auto key = a.by_scan ? frontend::RelationKey::kScanIndex : frontend::RelationKey::kStamp;
  if (a.by_scan && std::count(est.scan_index.begin(), est.scan_index.end(), -1L) > 0) {
    PrintError(a.est_path + " has no scan indices (--by-scan needs a CARMEN log or a cairn map CSV)");
    return 1;
  }
  const frontend::RelationErrors e = frontend::EvaluateRelations(est, rel, key, a.options.max_dt);
  const std::string pairing = a.by_scan ? "scan index" : "stamp";
  if (e.unpaired)
    std::cerr << "cairn: warning: " << e.unpaired << " of " << rel.size() << " relations of "
              << a.relations_path << " have an end with no unambiguous pose in " << a.est_path
              << " (by " << pairing << "; the first on line " << e.first_unpaired_line << ")\n";
  if (e.used == 0) {
    PrintError("no relation of " + a.relations_path + " pairs with " + a.est_path);
    return 1;
  }
  std::cout << std::setprecision(6) << "relations: " << e.used << " of " << rel.size() << " used (by "
            << pairing << "), in " << e.dimension << "D\n"
            << "translation " << e.trans.mean << " +- " << e.trans.std << " m (squared "
            << e.trans_sq.mean << " +- " << e.trans_sq.std << " m^2, max " << e.trans.max << " m)\n"
            << "rotation " << e.rot_deg.mean << " +- " << e.rot_deg.std << " deg (squared "
            << e.rot_sq_deg2.mean << " +- " << e.rot_sq_deg2.std << " deg^2, max " << e.rot_deg.max
            << " deg)\n";
  if (!a.json_path.empty()) {
    Json j;
    j["relations"] = rel.size();
    j["used"] = e.used;
    j["unpaired"] = e.unpaired;
    j["pairing"] = pairing;
    if (!a.by_scan) PutNumber(j, "max_dt", a.options.max_dt);
    j["dimension"] = e.dimension;
    PutStats(j, "trans", e.trans);
    PutStats(j, "rot_deg", e.rot_deg);
    PutStats(j, "trans_sq", e.trans_sq);
    PutStats(j, "rot_sq_deg2", e.rot_sq_deg2);
    outputs.Write(a.json_path, [&](std::ostream& o) { o << DumpJson(j); });
    outputs.Commit();
  }
  return 0;
}

// The usage errors of the arguments, printed; false when there is one.
bool CheckArgs(EvalArgs& a) {
  if (a.relations_path.empty() == a.ref_path.empty()) {
    PrintError(a.relations_path.empty() ? "missing REF (or --relations FILE)"
                                        : "--relations takes the estimate alone, not REF");
    return false;
  }
  if (a.by_scan && a.relations_path.empty()) {
    PrintError("--by-scan applies to --relations");
    return false;
  }
  if (!(a.options.segment > 0)) {
    PrintError("--segment must be positive");
    return false;
  }
  if (!(a.options.max_dt >= 0)) {
    PrintError("--max-dt must not be negative");
    return false;
  }
  if (!frontend::ParseAlignment(a.align, &a.options.align)) {
    PrintError("--align must be none, se3 or sim3, not '" + a.align + "'");
    return false;
  }
  return true;
}

int RunEval(int argc, char** argv) {
  EvalArgs a;
  ArgParser args("eval EST REF [--json FILE] [--align none|se3|sim3] [--max-dt S]\n"
                 "       cairn eval --relations FILE EST [--by-scan] [--max-dt S] [--json FILE]",
                 kDescription);
  args.Positional("EST", &a.est_path, "estimated trajectory");
  args.Positional("REF", &a.ref_path, "reference trajectory (not with --relations)", false);
  args.Option("relations", &a.relations_path, "FILE",
              "relations file (t1 t2 x y z roll pitch yaw): the benchmark's relative errors");
  args.Flag("by-scan", &a.by_scan, "--relations: t1 and t2 are 0-based scan indices");
  args.Option("json", &a.json_path, "FILE", "also write the figures as JSON");
  args.Option("segment", &a.options.segment, "M", "RPE segment length in metres of reference path");
  args.Option("align", &a.align, "HOW", "none, se3 or sim3 (se3: rigid; sim3: with scale)");
  args.Option("max-dt", &a.options.max_dt, "S", "largest stamp difference of a pair, seconds");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (!CheckArgs(a)) return 2;
  CommandOutputs outputs;
  outputs.Input(a.est_path);
  outputs.Input(a.relations_path.empty() ? a.ref_path : a.relations_path);
  outputs.Output(a.json_path);
  outputs.Check();
  if (!a.relations_path.empty()) return RunRelations(a, outputs);
  const frontend::Trajectory est = frontend::ReadTrajectory(a.est_path);
  const frontend::Trajectory ref = frontend::ReadTrajectory(a.ref_path);
  const frontend::TrajectoryErrors e = frontend::EvaluateTrajectory(est, ref, a.options);
  if (e.matched < est.size())
    std::cerr << "cairn: warning: " << est.size() - e.matched << " of " << est.size() << " poses of "
              << a.est_path << " have no unambiguous partner in " << a.ref_path << " ("
              << PairingText(a, e.pairing) << ")\n";
  if (e.matched < 2) {
    PrintError("only " + std::to_string(e.matched) + " poses of " + a.est_path + " pair with " +
               a.ref_path + " (need 2; " + PairingText(a, e.pairing) + ")");
    return 1;
  }
  PrintReport(a, est, ref, e);
  if (!a.json_path.empty()) {
    outputs.Write(a.json_path, [&](std::ostream& o) { o << DumpJson(ToJson(a, est, ref, e)); });
    outputs.Commit();
  }
  return 0;
}

}  // namespace

CAIRN_COMMAND("eval", "trajectory errors (ATE, RPE) of an estimate against a reference", RunEval);

}  // namespace cairn::tools
