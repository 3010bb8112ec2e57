// Pairwise consistency of loop closures (PCM, Mangelson et al. 2018): two
// loop closures and the odometry between their ends close a cycle, whose
// error is tested against its covariance. The largest set of mutually
// consistent loop closures is what SolveRejectingOutliers trusts first;
// wrong loop closures that agree with each other (perceptual aliasing) agree
// with few of the rest.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// The odometry chains of a graph (edges between consecutive ids), as prefix
// products and accumulated covariances, so that the cycle any two loop
// closures close is tested in constant time however far apart they lie.
class CycleTester {
 public:
  // Throws std::invalid_argument when the graph has landmarks.
  explicit CycleTester(const PoseGraph& graph);
  ~CycleTester();
  CycleTester(const CycleTester&) = delete;
  CycleTester& operator=(const CycleTester&) = delete;

  size_t size() const;  // loop closures, in edge order
  // The chi2 of the cycle loop closures i and j (indices among the loop
  // closures) close with the odometry between their ends (the two ways of
  // joining the ends, the shorter odometry taken), against the first-order
  // propagated covariance of all the measurements in it (odometry steps that
  // both paths take counted once). NaN when no odometry joins the ends.
  // For two good loop closures it is chi2-distributed with 3 (2D) or 6 (3D)
  // degrees of freedom.
  double PairChi2(size_t i, size_t j) const;
  // The loop closure's ends, lower id first.
  std::pair<int64_t, int64_t> Ends(size_t i) const;

  struct Impl;  // the chains, per dimension (pairwise_consistency.cpp)

 private:
  Impl* impl_;
};

struct ConsistentSetOptions {
  double threshold_chi2 = 0;  // a pair is inconsistent beyond it (required, > 0)
  // Up to this many loop closures, every pair is tested and the largest set
  // of mutually consistent ones is found exactly (branch and bound).
  size_t exact_limit = 60;
  // Beyond that, each loop closure is tested against the loop closures whose
  // ends both lie within `window` ids of its own (the cycle is short there
  // and the test sharpest), against `medium` at most of those within `reach`
  // ids, and against `partners` others at random; a set without conflicts
  // among the tested pairs is grown greedily.
  int window = 20;
  int reach = 200;
  int medium = 60;
  int partners = 20;
  uint64_t seed = 1;
  // Threads for the pair tests (0: one per hardware thread); the result is
  // the same for any count.
  int threads = 0;
  // Scale the threshold by the variance factor the short cycles show (the
  // median of their chi2 over chi2's median, at most 1): information far
  // looser than the noise tightens the test, never loosens it.
  bool scale_by_variance = true;
};

struct ConsistentSet {
  std::vector<bool> in;     // per loop closure, in edge order
  // Per loop closure: some loop closure whose cycle with it is short (ends
  // within twice the window) agrees with it. A place revisited is seen from
  // several poses in a row; a random wrong loop closure rarely has such a
  // neighbour, and its long cycles with the rest are weak evidence either way.
  std::vector<bool> supported;
  size_t tested_pairs = 0;  // pair tests made
  size_t conflicts = 0;     // inconsistent pairs among them
  bool exact = false;       // every pair tested and the maximum found
  double variance_factor = 1;  // the threshold was threshold_chi2 times this
};

// The largest set of loop closures no two of which are inconsistent: exact
// for few loop closures, else a greedy approximation (the loop closure in
// most conflicts with the rest goes first, until none are left).
ConsistentSet MaximumConsistentSet(const PoseGraph& graph, const ConsistentSetOptions& options);

}  // namespace cairn
