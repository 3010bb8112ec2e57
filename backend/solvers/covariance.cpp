#include "cairn/solvers/covariance.h"

#include <ceres/covariance.h>

#include <cstdlib>
#include <stdexcept>
#include <utility>

namespace cairn {

std::vector<Eigen::MatrixXd> CeresMarginalCovariances(ceres::Problem& problem,
                                                      const std::vector<const double*>& blocks,
                                                      int threads) {
  std::vector<Eigen::MatrixXd> out;
  std::vector<std::pair<const double*, const double*>> pairs;
  for (const double* b : blocks) {
    const int tangent = problem.ParameterBlockTangentSize(b);
    out.push_back(Eigen::MatrixXd::Zero(tangent, tangent));
    // Ceres would answer zeros for a constant block too; asking for it only
    // costs a Jacobian column.
    if (!problem.IsParameterBlockConstant(b)) pairs.emplace_back(b, b);
  }
  if (pairs.empty()) return out;
  ceres::Covariance::Options options;
  options.num_threads = threads;
  // SPARSE_QR (the default) factors the Jacobian, not J^T J: it never squares
  // the condition number, so it is an independent check on the Cholesky path.
  options.algorithm_type = ceres::SPARSE_QR;
  ceres::Covariance covariance(options);
  if (!covariance.Compute(pairs, &problem))
    throw std::runtime_error("Ceres could not compute the covariance (rank-deficient Jacobian)");
  for (size_t k = 0; k < blocks.size(); ++k) {
    if (problem.IsParameterBlockConstant(blocks[k])) continue;
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(out[k].rows(),
                                                                             out[k].cols());
    covariance.GetCovarianceBlockInTangentSpace(blocks[k], blocks[k], c.data());
    out[k] = c;
  }
  return out;
}

std::vector<Eigen::MatrixXd> MarginalCovariances(const PoseGraph& graph,
                                                 const std::vector<int64_t>& ids,
                                                 SolverKind solver,
                                                 const RobustLoss& loop_closure_loss) {
  IncrementalOptions options;
  options.loop_closure_loss = loop_closure_loss;
  IncrementalOptimizer optimizer(graph, options);
  return optimizer.MarginalCovariances(ids, solver);
}

std::vector<int64_t> ParseIdList(const std::string& text) {
  std::vector<int64_t> ids;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    char* end = nullptr;
    const long long id = std::strtoll(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0')
      throw std::invalid_argument("bad vertex id '" + item + "' in '" + text +
                                  "' (expected ids separated by commas, e.g. 3,17,42)");
    ids.push_back(id);
    pos = comma + 1;
  }
  return ids;
}

}  // namespace cairn
