#include "cairn/robust/local_consistency.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "cairn/graph/geometry.h"

namespace cairn {

// A measurement with its covariance, carried around the short cycle that two
// loop closures close with the odometry between their ends (the poses right
// perturbations carried past each other with InverseAdjoint).
namespace {

template <typename Pose>
struct Measured {
  Pose z;
  Eigen::MatrixXd cov;  // of the right perturbation, (t, w) coordinates
  Measured Inverse() const {
    const Eigen::MatrixXd ad = InverseAdjoint(z.Inverse());  // Ad(z)
    return {z.Inverse(), ad * cov * ad.transpose()};
  }
};

template <typename Pose>
Measured<Pose> MeasurementOf(const PoseGraph& graph, const Edge& e) {
  Measured<Pose> m{ToPose<Pose>(e.z), {}};
  if (graph.dimension() == 2) {
    m.cov = e.information.topLeftCorner<3, 3>().inverse();
  } else {
    // The factor's rotation error is the quaternion's vector part, w / 2.
    Eigen::VectorXd scale(6);
    scale << 1, 1, 1, 2, 2, 2;
    m.cov = scale.asDiagonal() * e.information.inverse() * scale.asDiagonal();
  }
  return m;
}

template <typename Pose>
std::vector<int> LocalSupport(const PoseGraph& graph, int window, double threshold) {
  std::unordered_map<int64_t, Measured<Pose>> step;  // odometry id -> id + 1
  struct Closure {
    int64_t a, b;  // a < b
    Measured<Pose> m;
  };
  std::vector<Closure> closures;
  std::vector<int> support;
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    const Measured<Pose> m = MeasurementOf<Pose>(graph, e);
    if (e.kind == EdgeKind::kOdometry) {
      if (e.to == e.from + 1) step.emplace(e.from, m);
      else if (e.from == e.to + 1) step.emplace(e.to, m.Inverse());
    } else if (e.kind == EdgeKind::kLoopClosure) {
      closures.push_back(e.from < e.to ? Closure{e.from, e.to, m} : Closure{e.to, e.from, m.Inverse()});
    }
  }
  support.assign(closures.size(), 0);
  // The measurements of a path along the odometry, as factors of a product.
  auto path = [&](int64_t from, int64_t to, std::vector<Measured<Pose>>* factors) {
    for (int64_t k = from; k < to; ++k) {
      const auto it = step.find(k);
      if (it == step.end()) return false;
      factors->push_back(it->second);
    }
    for (int64_t k = from - 1; k >= to; --k) {
      const auto it = step.find(k);
      if (it == step.end()) return false;
      factors->push_back(it->second.Inverse());
    }
    return true;
  };
  auto agree = [&](const Closure& i, const Closure& j) {
    std::vector<Measured<Pose>> f;
    if (!path(i.a, j.a, &f)) return false;
    f.push_back(j.m);
    if (!path(j.b, i.b, &f)) return false;
    Pose s;  // the product of the factors after the current one
    Eigen::MatrixXd cov = i.m.cov;
    for (size_t k = f.size(); k-- > 0;) {
      const Eigen::MatrixXd ad = InverseAdjoint(s);
      cov += ad * f[k].cov * ad.transpose();
      s = f[k].z * s;
    }
    const Eigen::VectorXd e = LogMap(i.m.z.Inverse() * s);
    return e.dot(cov.ldlt().solve(e)) <= threshold;
  };
  // Buckets of window x window ids; neighbours lie in the 3 x 3 around.
  const int64_t w = std::max(window, 1);
  auto key = [&](int64_t a, int64_t b) { return std::make_pair(a / w, b / w); };
  std::map<std::pair<int64_t, int64_t>, std::vector<size_t>> buckets;
  for (size_t i = 0; i < closures.size(); ++i)
    buckets[key(closures[i].a, closures[i].b)].push_back(i);
  for (size_t i = 0; i < closures.size(); ++i) {
    const auto [ka, kb] = key(closures[i].a, closures[i].b);
    for (int64_t da = -1; da <= 1; ++da)
      for (int64_t db = -1; db <= 1; ++db) {
        const auto it = buckets.find({ka + da, kb + db});
        if (it == buckets.end()) continue;
        for (size_t j : it->second) {
          if (j <= i || std::abs(closures[j].a - closures[i].a) > window ||
              std::abs(closures[j].b - closures[i].b) > window)
            continue;
          if (agree(closures[i], closures[j])) {
            ++support[i];
            ++support[j];
          }
        }
      }
  }
  return support;
}

}  // namespace

std::vector<int> LocalLoopClosureSupport(const PoseGraph& graph, int window,
                                         double threshold_chi2) {
  if (window < 1) throw std::invalid_argument("the consistency window must be at least 1");
  RequireNoLandmarks(graph, "the local consistency check");
  return graph.dimension() == 2 ? LocalSupport<SE2>(graph, window, threshold_chi2)
                                : LocalSupport<SE3>(graph, window, threshold_chi2);
}

}  // namespace cairn
