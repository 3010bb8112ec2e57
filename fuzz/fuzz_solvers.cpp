// libFuzzer target: both solvers on tiny graphs built from the bytes (0 to
// 6 vertices, 2D or 3D, random edges, FIX flags, priors), degenerate ones
// included. Each must return; when both converge they must agree on chi2.
// The measurements are a ground truth's plus small noise and the start is
// near the truth, so that both solvers walk to the same minimum.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"

namespace {

// The fuzzer's bytes, read from the front; zeros once they run out.
class Bytes {
 public:
  Bytes(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  uint8_t Next() { return pos_ < size_ ? data_[pos_++] : 0; }
  // In [lo, hi].
  double Real(double lo, double hi) { return lo + (hi - lo) * Next() / 255.0; }
  bool Empty() const { return pos_ >= size_; }

 private:
  const uint8_t* data_;
  size_t size_, pos_ = 0;
};

cairn::PoseParams Pose(int dim, Bytes& in, double scale) {
  if (dim == 2) return cairn::ToParams(cairn::SE2(in.Real(-scale, scale), in.Real(-scale, scale),
                                                  in.Real(-1, 1) * scale));
  const Eigen::Vector3d axis(in.Real(-1, 1), in.Real(-1, 1), in.Real(-1, 1));
  const double angle = in.Real(-1, 1) * scale;
  const Eigen::Quaterniond q = axis.norm() > 1e-6
                                   ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()))
                                   : Eigen::Quaterniond::Identity();
  return cairn::ToParams(cairn::SE3(
      q, Eigen::Vector3d(in.Real(-scale, scale), in.Real(-scale, scale), in.Real(-scale, scale))));
}

// a * Exp(small): in 2D by parameters, in 3D by SE3's own composition.
cairn::PoseParams Perturb(int dim, const cairn::PoseParams& a, Bytes& in, double scale) {
  const cairn::PoseParams d = Pose(dim, in, scale);
  if (dim == 2) return cairn::ToParams(cairn::ToSE2(a) * cairn::ToSE2(d));
  return cairn::ToParams(cairn::ToSE3(a) * cairn::ToSE3(d));
}

cairn::PoseGraph Build(Bytes& in) {
  const uint8_t head = in.Next();
  const int dim = head & 1 ? 3 : 2;
  const int n = (head >> 1) % 7;
  cairn::PoseGraph truth(dim), graph(dim);
  for (int i = 0; i < n; ++i) {
    const bool fixed = (in.Next() & 7) == 0;
    const cairn::PoseParams x = Pose(dim, in, 3.0);
    truth.AddVertex(i, x, fixed);
    graph.AddVertex(i, Perturb(dim, x, in, 0.05), fixed);
  }
  const int edges = n == 0 ? 0 : in.Next() % 13;
  for (int k = 0; k < edges && !in.Empty(); ++k) {
    cairn::Edge e;
    const uint8_t kind = in.Next();
    e.from = in.Next() % n;
    e.to = in.Next() % n;
    e.kind = kind % 5 == 0 ? cairn::EdgeKind::kPrior
             : kind % 5 == 1 ? cairn::EdgeKind::kLoopClosure
                             : cairn::EdgeKind::kOdometry;
    if (!e.IsPrior() && e.from == e.to) continue;
    const cairn::PoseParams& xi = truth.vertex(e.from).x;
    cairn::PoseParams z = xi;
    if (!e.IsPrior()) {
      const cairn::PoseParams& xj = truth.vertex(e.to).x;
      z = dim == 2 ? cairn::ToParams(cairn::ToSE2(xi).Between(cairn::ToSE2(xj)))
                   : cairn::ToParams(cairn::ToSE3(xi).Between(cairn::ToSE3(xj)));
    }
    e.z = Perturb(dim, z, in, 0.01);
    e.information.setZero();
    const int t = dim == 2 ? 3 : 6;
    for (int r = 0; r < t; ++r) e.information(r, r) = in.Real(0.5, 200);
    graph.AddEdge(e);
  }
  return graph;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Bytes in(data, size);
  const uint8_t choice = in.Next();
  const cairn::PoseGraph graph = Build(in);
  cairn::SolverOptions common;
  common.max_iterations = 50;
  common.function_tolerance = 1e-14;
  common.gradient_tolerance = 1e-14;
  common.parameter_tolerance = 1e-14;
  common.threads = 1 + (choice & 1);
  cairn::CeresOptions co;
  static_cast<cairn::SolverOptions&>(co) = common;
  cairn::GaussNewtonOptions go;
  static_cast<cairn::SolverOptions&>(go) = common;
  static const cairn::CholeskyKind kKinds[] = {
      cairn::CholeskyKind::kAuto,       cairn::CholeskyKind::kTwoHalves,
      cairn::CholeskyKind::kSupernodal, cairn::CholeskyKind::kSimplicial,
      cairn::CholeskyKind::kSupernodalOrSimplicial, cairn::CholeskyKind::kEigenLDLT};
  go.linear_solver = kKinds[(choice >> 1) % 6];

  cairn::PoseGraph gc = graph, gg = graph;
  const cairn::SolveResult rc = cairn::SolveWithCeres(gc, co);
  const cairn::SolveResult rg = cairn::SolveGaussNewton(gg, go);
  if (rc.converged && rg.converged && rc.usable && rg.usable) {
    const double scale = std::max({1.0, rc.initial_chi2, rc.final_chi2});
    if (!(std::abs(rc.final_chi2 - rg.final_chi2) <= 1e-6 * scale)) {
      std::fprintf(stderr, "chi2 differs: ceres %.17g, gn %.17g (initial %.17g)\n", rc.final_chi2,
                   rg.final_chi2, rc.initial_chi2);
      std::abort();
    }
  }
  return 0;
}
