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

enum class InitMethod { kFile, kOdometry, kSpanningTree, kChordal };
// Parses "file", "odometry", "spanning-tree", "chordal"; throws
// std::invalid_argument otherwise.
InitMethod ParseInitMethod(const std::string& name);
const char* ToString(InitMethod method);

struct InitReport {
  InitMethod method = InitMethod::kFile;
  double time_s = 0;  // the initialiser alone
  double chi2 = 0;    // g2o's chi-squared of the estimate it leaves
};

// Runs one initialiser on the graph and reports its time and chi-squared.
InitReport Initialize(PoseGraph& graph, InitMethod method);

}  // namespace cairn
