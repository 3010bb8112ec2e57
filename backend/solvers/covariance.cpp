#include "cairn/solvers/covariance.h"

#include <cstdlib>
#include <stdexcept>
#include <utility>

#include "cairn/solvers/incremental.h"

namespace cairn {

std::vector<Eigen::MatrixXd> MarginalCovariances(const PoseGraph& graph,
                                                 const std::vector<int64_t>& ids,
                                                 SolverKind solver,
                                                 const RobustLoss& loop_closure_loss) {
  IncrementalOptions options;
  options.ceres.loop_closure_loss = options.gauss_newton.loop_closure_loss = loop_closure_loss;
  IncrementalOptimizer optimizer(graph, options);
  return optimizer.MarginalCovariances(ids, solver);
}

}  // namespace cairn
