// cairn simulate: synthetic pose graphs with ground truth.
#include <cstdio>
#include <iostream>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/frontend/laser_simulator.h"
#include "cairn/graph/simulate.h"
#include "tools/args.h"
#include "tools/command.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

// OUT_truth with OUT's own extension (any case), .g2o when it has none.
std::string DefaultTruthPath(const std::string& out) {
  if (!GraphFormatOf(out)) return out + "_truth.g2o";
  const size_t dot = out.rfind('.');
  return out.substr(0, dot) + "_truth" + out.substr(dot);
}

// --laser-log: a building, a drive through it and its CARMEN log.
int WriteLaserLog(const std::string& path, frontend::LaserSimulationOptions o) {
  CommandOutputs outputs;
  outputs.Output(path);
  outputs.Check();
  const frontend::LaserSimulation sim = frontend::SimulateLaserLog(o);
  outputs.Write(path, [&](std::ostream& os) { frontend::WriteCarmenLog(sim, os); });
  outputs.Commit();
  std::fprintf(stderr, "wrote %s (%zu scans of %d beams, a %.0f x %.0f m building, seed %llu)\n",
               path.c_str(), sim.truth.size(), o.beams, sim.width, sim.height,
               static_cast<unsigned long long>(o.seed));
  return 0;
}

int RunSimulate(int argc, char** argv) {
  SimulationOptions o;
  frontend::LaserSimulationOptions lo;
  std::string out, truth_path, laser_log;
  int seed = 1;
  ArgParser args(
      "simulate -o OUT.g2o [--dim 2|3] [--poses N] [options]\n"
      "       cairn simulate --laser-log OUT.log [--seed S] [laser options]",
      "Writes a synthetic pose graph with noisy measurements and its ground truth.\n"
      "2D: a random walk on a 1 m Manhattan grid, with a loop closure (by chance)\n"
      "whenever the walk revisits a place. 3D: circles climbing a sphere (as g2o's\n"
      "create_sphere makes), with loop closures to the previous circle. The noisy\n"
      "graph's estimate chains its odometry; the truth file holds the same edges\n"
      "with the vertices at their true poses. --landmarks N adds point landmarks\n"
      "(VERTEX_XY / VERTEX_TRACKXYZ), each seen by every pose within the range\n"
      "(EDGE_SE2_XY / EDGE_SE3_TRACKXYZ, translation noise per axis) and placed in\n"
      "the noisy graph from its first observation. The same seed gives the same files.\n"
      "--laser-log instead writes a CARMEN laser log for `cairn map`: a random building\n"
      "(corridors closing loops, rooms with doors, furniture), a drive through it, a\n"
      "laser and noisy wheel odometry with a systematic error; the FLASER lines carry\n"
      "the true poses, so `cairn map` reports its error against the truth.");
  args.Option("output", &out, "FILE", "the noisy graph (g2o; TORO if *.graph)");
  args.Alias("-o", "output");
  args.Option("truth", &truth_path, "FILE", "the ground truth [default: OUT_truth.g2o, or .graph]");
  args.Option("dim", &o.dimension, "2|3", "2D Manhattan walk or 3D sphere");
  args.Option("poses", &o.poses, "N", "number of poses");
  args.Option("translation-noise", &o.translation_noise, "M",
              "standard deviation of the translation noise per axis, m");
  args.Option("rotation-noise", &o.rotation_noise, "RAD",
              "standard deviation of the rotation noise per axis, rad");
  args.Option("loop-probability", &o.loop_probability, "P",
              "chance that a revisit becomes a loop closure");
  args.Option("outliers", &o.outliers, "N", "wrong loop closures to add");
  args.Option("nodes-per-lap", &o.nodes_per_lap, "N", "3D: poses per circle");
  args.Option("radius", &o.radius, "M", "3D: radius of the sphere");
  args.Option("landmarks", &o.landmarks, "N", "point landmarks to add (ids after the poses')");
  args.Option("landmark-range", &o.landmark_range, "M",
              "how far a pose sees a landmark, m [default: 3 in 2D, 10 in 3D]");
  args.Option("seed", &seed, "S", "random seed");
  args.Option("laser-log", &laser_log, "FILE", "write a simulated CARMEN laser log instead");
  args.Option("path-length", &lo.path_length, "M", "laser log: metres driven");
  args.Option("scan-spacing", &lo.scan_spacing, "M", "laser log: metres between scans");
  args.Option("beams", &lo.beams, "N", "laser log: beams over the 180 degree field of view");
  args.Option("max-range", &lo.max_range, "M", "laser log: the laser's range, m");
  args.Option("range-noise", &lo.range_noise, "M", "laser log: range noise, m");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (!laser_log.empty()) {
    if (!out.empty()) {
      PrintError("simulate writes either a graph (-o) or a laser log (--laser-log)");
      return 2;
    }
    if (lo.beams < 2 || !(lo.path_length > 0) || !(lo.scan_spacing > 0) || !(lo.max_range > 0) ||
        !(lo.range_noise >= 0)) {
      PrintError("simulate: --beams must be at least 2, --path-length, --scan-spacing and "
                 "--max-range positive, --range-noise not negative");
      return 2;
    }
    lo.seed = static_cast<uint64_t>(seed);
    return WriteLaserLog(laser_log, lo);
  }
  if (out.empty()) {
    PrintError("simulate needs an output file (-o OUT.g2o)");
    return 2;
  }
  if (truth_path.empty()) truth_path = DefaultTruthPath(out);
  o.seed = static_cast<uint64_t>(seed);
  CommandOutputs outputs;
  outputs.GraphOutput(out);
  outputs.GraphOutput(truth_path);
  outputs.Check();

  const Simulation sim = Simulate(o);
  outputs.CheckGraphFits(sim.noisy);
  outputs.WriteGraph(out, sim.noisy);
  outputs.WriteGraph(truth_path, sim.truth);
  outputs.Commit();
  std::fprintf(stderr,
               "wrote %s (%zu vertices, %zu odometry edges, %zu loop closures of which %zu "
               "wrong, %zu landmarks, %zu landmark observations; chi2 %.6g) and %s\n",
               out.c_str(), sim.noisy.vertices().size(), sim.noisy.CountEdges(EdgeKind::kOdometry),
               sim.noisy.CountEdges(EdgeKind::kLoopClosure), sim.outliers.size(),
               sim.noisy.CountLandmarks(), sim.noisy.CountEdges(EdgeKind::kLandmark),
               Chi2(sim.noisy), truth_path.c_str());
  return 0;
}

}  // namespace

CAIRN_COMMAND("simulate", "write a synthetic noisy pose graph and its ground truth", RunSimulate);

}  // namespace cairn::tools
