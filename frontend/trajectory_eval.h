// Trajectory errors as evo and the TUM benchmark define them: the pairing of
// an estimate's poses with a reference's (by nearest stamp within a
// tolerance, by vertex id or by scan), the alignment of the estimate onto the
// reference (none, rigid, or rigid with scale: Umeyama), the absolute error
// of each aligned pose and the relative error over segments of reference path.
// In the plane when both trajectories are planar, in space otherwise.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "cairn/frontend/trajectory.h"

namespace cairn::frontend {

// --align none|se3|sim3: in 2D, se3 is the planar rigid motion and sim3 the
// planar similarity.
enum class Alignment { kNone, kRigid, kSimilarity };
const char* AlignmentName(Alignment a);                       // "none", "se3", "sim3"
bool ParseAlignment(const std::string& text, Alignment* out);  // false: not a name

enum class Pairing { kScanIndex, kVertexId, kStamp };
const char* PairingName(Pairing p);  // "scan index", "vertex id", "stamp"

struct EvalOptions {
  double segment = 1.0;  // RPE segment length, metres of reference path
  double max_dt = 0.01;  // seconds between paired stamps at most (evo's default)
  Alignment align = Alignment::kRigid;
};

// evo's statistics of a set of errors (std is the population's).
struct ErrorStats {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
  size_t count = 0;
};
ErrorStats Summarize(std::vector<double> errors);

struct TrajectoryErrors {
  Pairing pairing = Pairing::kStamp;
  size_t matched = 0;                      // poses paired
  size_t unpaired_est = 0, unpaired_ref = 0;
  int dimension = 2;                       // 3 when either input is 3D (a planar one lifted)
  double scale = 1;                        // of the sim3 alignment; 1 otherwise
  double ate_rmse = 0;                     // metres (= ate.rmse)
  double rpe_trans_rmse = 0;               // metres, over segments of `segment` m
  double rpe_rot_rmse_deg = 0;             // degrees
  size_t rpe_pairs = 0;
  ErrorStats ate;          // |position of aligned est - position of ref|, m
  ErrorStats ate_rot_deg;  // angle of ref^-1 * aligned est, degrees
  ErrorStats rpe_trans;    // |translation of (dref^-1 dest)| over each segment, m
  ErrorStats rpe_rot_deg;  // angle of (dref^-1 dest), degrees
};

// Pairs poses of `est` and `ref`, sorted by est index: by scan index when
// both know it; a g2o graph's vertex k with the k-th pose of the other file
// (or vertex k of another graph); else by the nearest stamp within `max_dt`
// seconds, each pose of either side used at most once (the closest pairs
// first). Poses that share a stamp (some logs print times too coarsely to
// tell scans apart) pair in order of appearance with a group of as many at
// the nearest stamp, and are left out otherwise.
std::vector<std::pair<size_t, size_t>> Associate(const Trajectory& est, const Trajectory& ref,
                                                 double max_dt = 0.01);
Pairing PairingOf(const Trajectory& est, const Trajectory& ref);

// ATE after aligning est onto ref as `options.align` says (a least-squares
// fit of the paired positions); RPE from each paired pose to the first later
// one at least `options.segment` metres further along the reference path,
// its translation scaled by the alignment's scale. With fewer than 2 pairs
// only the pairing counts are filled in.
TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& ref,
                                    const EvalOptions& options = {});

}  // namespace cairn::frontend
