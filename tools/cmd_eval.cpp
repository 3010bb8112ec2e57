// `cairn eval EST REF`: trajectory errors between an estimate and a reference.
#include <cstdio>
#include <iomanip>
#include <iostream>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/frontend/trajectory.h"
#include "tools/args.h"
#include "tools/command.h"
#include "tools/json.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

int RunEval(int argc, char** argv) {
  std::string est_path, ref_path, json_path;
  double segment = 1.0;
  ArgParser args("eval EST REF [--json FILE]",
                 "Absolute trajectory error (RMSE of positions after the best rigid alignment of\n"
                 "EST onto REF) and relative pose error over segments of reference path, for\n"
                 "planar trajectories. Each file is TUM text ('t x y z qx qy qz qw'), a g2o graph\n"
                 "(its VERTEX_SE2 poses; landmarks are not part of the trajectory) or a CARMEN log (the poses on its laser lines). Poses pair\n"
                 "by timestamp (equal stamps in order of appearance, and only when both files hold as\n"
                 "many: else they are left out, with a warning); two CARMEN logs pair by scan;\n"
                 "a g2o graph has no times, so vertex k pairs with the k-th pose of the other file\n"
                 "(e.g. 'cairn map' numbers keyframes as PREFIX_trajectory.tum lists them).");
  args.Positional("EST", &est_path, "estimated trajectory");
  args.Positional("REF", &ref_path, "reference trajectory");
  args.Option("json", &json_path, "FILE", "also write the figures as JSON");
  args.Option("segment", &segment, "M", "RPE segment length in metres of reference path");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (!(segment > 0)) {
    PrintError("--segment must be positive");
    return 2;
  }
  CommandOutputs outputs;
  outputs.Input(est_path);
  outputs.Input(ref_path);
  outputs.Output(json_path);
  outputs.Check();
  const frontend::Trajectory est = frontend::ReadTrajectory(est_path);
  const frontend::Trajectory ref = frontend::ReadTrajectory(ref_path);
  const frontend::TrajectoryErrors e = frontend::EvaluateTrajectory(est, ref, segment);
  if (e.matched < est.size())
    std::cerr << "cairn: warning: " << est.size() - e.matched << " of " << est.size()
              << " poses of " << est_path << " have no unambiguous partner in " << ref_path
              << " (missing or repeated timestamps)\n";
  if (e.matched < 2) {
    PrintError("only " + std::to_string(e.matched) + " poses of " + est_path + " pair with " +
               ref_path + " (need 2)");
    return 1;
  }
  std::cout << std::setprecision(6) << "matched " << e.matched << " of " << est.size()
            << " poses\nATE RMSE " << e.ate_rmse << " m\nRPE RMSE (" << segment << " m) "
            << e.rpe_trans_rmse << " m, " << e.rpe_rot_rmse_deg << " deg over " << e.rpe_pairs
            << " segments\n";
  if (!json_path.empty()) {
    outputs.Write(json_path, [&](std::ostream& o) {
      Json j;
      PutNumber(j, "ate_rmse", e.ate_rmse);
      PutNumber(j, "rpe_trans_rmse", e.rpe_trans_rmse);
      PutNumber(j, "rpe_rot_rmse_deg", e.rpe_rot_rmse_deg);
      j["matched"] = e.matched;
      o << DumpJson(j);
    });
    outputs.Commit();
  }
  return 0;
}

}  // namespace

CAIRN_COMMAND("eval", "trajectory errors (ATE, RPE) of an estimate against a reference", RunEval);

}  // namespace cairn::tools
