// Initial estimates built from the edges alone, for graphs whose vertices
// carry no (or no useful) estimate. (The graph's connected components and
// the spanning-tree chaining itself are the graph model's: pose_graph.h.)
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// Sets every vertex's estimate by chaining measurements outward along a
// spanning tree that prefers the most certain edges: ChainAlongSpanningTree
// (pose_graph.h), as an initialiser.
void InitializeBySpanningTree(PoseGraph& graph);

// Chains the odometry edges (consecutive ids) outward from each component's
// root (its fixed vertex, else its lowest id); vertices no odometry chain
// reaches keep their estimate.
void InitializeByOdometry(PoseGraph& graph);

// Chordal relaxation: all rotations first, as the linear least-squares
// problem R_j = R_i Z_ij over unconstrained matrices (weighted by each
// edge's rotation information), each then projected back onto a rotation
// (by SVD in 3D, by normalising (cos, sin) in 2D); then all translations,
// linear once rotations are fixed, weighted by the translation information.
// Each component keeps its root's pose (its fixed vertex, else lowest id).
// Throws std::runtime_error if the linear systems are singular.
void InitializeChordal(PoseGraph& graph);

// kAuto: the file's vertices, or the chordal relaxation when that gives a
// lower chi2 (InitializeAuto); the default of `cairn optimize`.
enum class InitMethod { kFile, kOdometry, kSpanningTree, kChordal, kAuto };
// Parses "file", "odometry", "spanning-tree", "chordal", "auto"; throws
// std::invalid_argument otherwise.
InitMethod ParseInitMethod(const std::string& name);
const char* ToString(InitMethod method);

struct InitReport {
  InitMethod method = InitMethod::kFile;  // the one asked for
  InitMethod chosen = InitMethod::kFile;  // the one the estimate is from (kAuto: file or chordal)
  double time_s = 0;  // the initialiser alone
  double chi2 = 0;    // g2o's chi-squared of the estimate it leaves
  // kAuto only: the chi2 of both candidates (chordal: NaN if its linear
  // systems were singular).
  double file_chi2 = 0, chordal_chi2 = 0;
  // kAuto with a robust kernel: file_chi2 and chordal_chi2 are the robust
  // costs the choice compared (chi2 stays the plain chi2).
  bool robust_cost = false;
};

// A robust kernel on loop closures, as the cost a solve will weigh them by:
// rho of an edge's chi2 (empty: chi2 itself).
using LoopClosureRho = std::function<double(double chi2)>;

// Evaluates the estimate the graph holds (the file's vertices; for a file
// without vertices, the spanning tree the reader chained) and the chordal
// relaxation, by g2o's chi2, and keeps the lower; a tie keeps the file's.
// From a start of lower chi2 the solvers are less likely to end in a
// worse local minimum, and chordal costs less than the solve after it.
// With `rho`, both are compared by the cost the robust solve will minimise
// (loop closures through rho): the relaxation weighs every loop closure
// fully, so wrong ones bend it, and by plain chi2 that bent estimate can
// look better than an odometry start the kernel would solve from cleanly.
// The report's file_chi2 and chordal_chi2 are then those robust costs, its
// chi2 the plain chi2 of the start kept.
InitReport InitializeAuto(PoseGraph& graph, const LoopClosureRho& rho = {});
// kAuto's decision in one line, e.g. "initial estimate (auto): chordal, chi2
// 71.54 (file 4.414e+09)".
std::string DescribeAutoChoice(const InitReport& report);

// Runs one initialiser on the graph and reports its time and chi-squared.
// `rho` is used by kAuto only (InitializeAuto).
InitReport Initialize(PoseGraph& graph, InitMethod method, const LoopClosureRho& rho = {});

}  // namespace cairn
