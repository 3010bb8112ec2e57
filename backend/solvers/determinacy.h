// Whether a pose graph determines its poses, and the gauge the solvers hold
// where it does not by itself. With singular information matrices (a
// position-only prior, an edge that says nothing about rotation) a pose or
// a whole component can be left free in some direction; both solvers then
// refuse the problem with a message naming the vertex and the direction,
// instead of meeting a singular matrix.
#pragma once

#include <ceres/manifold.h>

#include <optional>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"

namespace cairn {

// Per vertex (in vertices() order) what the solvers hold constant. A FIX
// vertex is held. A component (landmark observations join it) anchored by
// neither a FIX pose nor a pose prior has its lowest-id touched pose held: a
// fixed landmark or a point prior does not anchor, the rotation about it
// stays free. A component whose priors fix its
// position but leave every rotation about it free (position-only priors at
// one place, e.g. a single GPS fix) has only the rotation of that vertex
// held: its rotation gauge. Any other gauge the priors leave partly free is
// in `undetermined`.
struct GraphGauge {
  std::vector<bool> held;
  std::vector<bool> rotation_held;
  std::string undetermined;  // empty when the gauge is complete
};
GraphGauge ComputeGauge(const PoseGraph& graph);

// Per vertex (in vertices() order): held constant during optimisation. FIX
// vertices are held; in each connected component that no FIX vertex and no
// prior anchors, the lowest-id vertex that an edge touches is held as that
// component's gauge, so that a graph in several pieces never leaves the
// normal equations singular. ComputeGauge's `held`; a
// caller that holds only whole poses misses a rotation gauge.
std::vector<bool> HeldConstant(const PoseGraph& graph);


// Empty when the problem (with `gauge` held) is determined as far as these
// checks see; else e.g. "vertex 17: rotation about z is not constrained by
// any edge". Only singular information can leave a pose free, so a graph
// without it costs one pass over the edges.
std::optional<std::string> FindUndetermined(const PoseGraph& graph, const GraphGauge& gauge);

// The pose manifold with the rotation held: its tangent is the translation
// part of `pose`'s (the first 2 or 3 coordinates). `pose` must outlive it.
class HeldRotationManifold final : public ceres::Manifold {
 public:
  HeldRotationManifold(const ceres::Manifold* pose, int translation_size)
      : pose_(pose), size_(translation_size) {}
  int AmbientSize() const override { return pose_->AmbientSize(); }
  int TangentSize() const override { return size_; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;

 private:
  const ceres::Manifold* pose_;
  int size_;
};

// Words for a direction in a pose's tangent (translation, then rotation):
// "rotation about z", "translation along (0.71, 0.71, 0)".
std::string DescribeDirection(const Eigen::VectorXd& v, int dimension);

}  // namespace cairn
