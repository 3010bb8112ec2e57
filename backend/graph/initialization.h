// Initial estimates built from the edges alone, for graphs whose vertices
// carry no (or no useful) estimate. (The graph's connected components and
// the spanning-tree chaining itself are the graph model's: pose_graph.h.)
#pragma once

#include <cstdint>
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
};

// Evaluates the estimate the graph holds (the file's vertices; for a file
// without vertices, the spanning tree the reader chained) and the chordal
// relaxation, by g2o's chi2, and keeps the lower; a tie keeps the file's.
// From a start of lower chi2 the solvers are less likely to end in a
// worse local minimum, and chordal costs less than the solve after it.
InitReport InitializeAuto(PoseGraph& graph);
// kAuto's decision in one line, e.g. "initial estimate (auto): chordal, chi2
// 71.54 (file 4.414e+09)".
std::string DescribeAutoChoice(const InitReport& report);

// Runs one initialiser on the graph and reports its time and chi-squared.
InitReport Initialize(PoseGraph& graph, InitMethod method);

}  // namespace cairn
