#include "backend/outliers.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <stdexcept>

#include "backend/chi2.h"

namespace cairn {

std::vector<VertexPair> AddWrongLoopClosures(PoseGraph& graph, int count, uint64_t seed) {
  if (count < 0) throw std::invalid_argument("the number of outliers must be non-negative");
  if (count == 0) return {};
  const auto& vertices = graph.vertices();
  if (vertices.size() < 3)
    throw std::invalid_argument("a graph of fewer than 3 vertices has no room for loop closures");
  std::set<VertexPair> joined;
  std::vector<const Edge*> closures, odometry;
  double reach = 0;  // the largest translation a loop closure measures
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior()) continue;
    joined.insert(std::minmax(e.from, e.to));
    if (e.kind == EdgeKind::kLoopClosure) {
      closures.push_back(&e);
      const double t = graph.dimension() == 2
                           ? std::hypot(e.z[0], e.z[1])
                           : std::sqrt(e.z[0] * e.z[0] + e.z[1] * e.z[1] + e.z[2] * e.z[2]);
      reach = std::max(reach, t);
    } else {
      odometry.push_back(&e);
    }
  }
  if (reach <= 0) reach = 5.0;  // no loop closure to learn from: a room's size
  std::vector<const Edge*>& pool = closures.empty() ? odometry : closures;
  Matrix6d info = Matrix6d::Identity();
  if (!pool.empty()) {
    // The median by trace: a typical loop closure, not the most certain.
    std::sort(pool.begin(), pool.end(), [](const Edge* a, const Edge* b) {
      return a->information.trace() < b->information.trace();
    });
    info = pool[pool.size() / 2]->information;
  }

  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, vertices.size() - 1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<VertexPair> added;
  const size_t max_tries = 1000 * static_cast<size_t>(count) + 1000;
  for (size_t tries = 0; added.size() < static_cast<size_t>(count); ++tries) {
    if (tries > max_tries)
      throw std::invalid_argument("could not find " + std::to_string(count) +
                                  " unjoined pairs of vertices");
    int64_t a = vertices[pick(rng)].id, b = vertices[pick(rng)].id;
    if (a > b) std::swap(a, b);
    // Consecutive ids read back as odometry; joined pairs would be duplicates.
    if (b - a < 2 || joined.count({a, b})) continue;
    Edge e;
    e.kind = EdgeKind::kLoopClosure;
    e.from = a;
    e.to = b;
    e.information = info;
    if (graph.dimension() == 2) {
      e.z = {reach * unit(rng), reach * unit(rng), M_PI * unit(rng)};
    } else {
      // A uniform rotation: a normalised 4D Gaussian.
      Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
      q.normalize();
      e.z = {reach * unit(rng), reach * unit(rng), reach * unit(rng), q.x(), q.y(), q.z(), q.w()};
    }
    graph.AddEdge(e);
    joined.insert({a, b});
    added.emplace_back(a, b);
  }
  return added;
}

double ChiSquaredQuantile(double p, int dof) {
  // The normal quantile by Acklam's rational approximation (upper region
  // by symmetry), then Wilson-Hilferty's cube.
  auto normal_quantile = [](double q) {
    const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                        1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00};
    const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                        6.680131188771972e+01, -1.328068155288572e+01};
    const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                        -2.549732539343734e+00, 4.374664141464968e+00, 2.938163982698783e+00};
    const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                        3.754408661907416e+00};
    auto tail = [&](double t) {
      const double u = std::sqrt(-2 * std::log(t));
      return (((((c[0] * u + c[1]) * u + c[2]) * u + c[3]) * u + c[4]) * u + c[5]) /
             ((((d[0] * u + d[1]) * u + d[2]) * u + d[3]) * u + 1);
    };
    if (q < 0.02425) return tail(q);
    if (q > 1 - 0.02425) return -tail(1 - q);
    const double u = q - 0.5, r = u * u;
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * u /
           (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  };
  if (!(p > 0 && p < 1) || dof < 1) throw std::invalid_argument("ChiSquaredQuantile: bad arguments");
  const double k = dof, h = 2.0 / (9 * k);
  const double v = 1 - h + normal_quantile(p) * std::sqrt(h);
  return k * v * v * v;
}

OutlierRejectionResult SolveRejectingOutliers(PoseGraph& graph, const GraphSolver& solve,
                                              const OutlierRejectionOptions& options) {
  OutlierRejectionResult out;
  const double c2 = options.threshold_chi2 > 0
                        ? options.threshold_chi2
                        : ChiSquaredQuantile(options.confidence, graph.TangentSize());
  out.threshold_chi2 = c2;
  const double initial_chi2 = Chi2(graph);
  std::vector<size_t> closures;
  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (graph.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);

  // The weighted problem: weights scale the loop closures' information. A
  // weight of 0 would leave a singular square root; a negligible one does not.
  PoseGraph work = graph;
  std::vector<double> w(closures.size(), 1.0);
  auto apply_weights = [&] {
    for (size_t i = 0; i < closures.size(); ++i)
      work.mutable_edges()[closures[i]].information =
          graph.edges()[closures[i]].information * std::max(w[i], 1e-9);
  };
  auto residuals = [&] {
    std::vector<double> r2(closures.size());
    for (size_t i = 0; i < closures.size(); ++i)
      r2[i] = EdgeChi2(work, graph.edges()[closures[i]]);  // unweighted, at work's estimate
    return r2;
  };

  // Least squares first: GNC's surrogate at mu -> 0 is the convex quadratic.
  out.solve = solve(work);
  out.rounds = 1;
  std::vector<double> r2 = residuals();
  const double r2_max = r2.empty() ? 0 : *std::max_element(r2.begin(), r2.end());
  if (r2_max > c2) {
    double mu = c2 / std::max(2 * r2_max - c2, 1e-12);
    for (int round = 0; round < options.max_rounds; ++round) {
      for (size_t i = 0; i < w.size(); ++i) {
        const double lo = mu / (mu + 1) * c2, hi = (mu + 1) / mu * c2;
        if (!std::isfinite(r2[i]) || r2[i] >= hi) w[i] = 0;
        else if (r2[i] <= lo) w[i] = 1;
        else w[i] = std::sqrt(c2 / r2[i] * mu * (mu + 1)) - mu;
      }
      apply_weights();
      out.solve = solve(work);
      ++out.rounds;
      r2 = residuals();
      double undecided = 0;
      for (double x : w) undecided += x * (1 - x);
      if (options.verbose)
        std::fprintf(stderr, "gnc round %d: mu %.3g, sum w(1-w) %.3g, chi2 %.6g\n", round + 1,
                     mu, undecided, out.solve.final_chi2);
      // Binary weights: the surrogate has become the truncated cost.
      if (undecided < 1e-6 * std::max<size_t>(1, w.size()) && mu > 1) break;
      mu *= options.mu_factor;
    }
  }

  // The verdict: a loop closure stays if its weight is up or it now fits.
  PoseGraph inliers(graph.dimension());
  for (const Vertex& v : work.vertices()) inliers.AddVertex(v.id, v.x, v.fixed);
  std::vector<bool> rejected(graph.edges().size(), false);
  for (size_t i = 0; i < closures.size(); ++i)
    if (w[i] < 0.5 && !(r2[i] <= c2)) rejected[closures[i]] = true;
  for (size_t k = 0; k < graph.edges().size(); ++k) {
    const Edge& e = graph.edges()[k];
    if (rejected[k]) out.rejected.emplace_back(e.from, e.to);
    else inliers.AddEdge(e);
  }
  out.solve = solve(inliers);
  ++out.rounds;
  auto& dst = graph.vertices();
  for (size_t i = 0; i < dst.size(); ++i) dst[i].x = inliers.vertices()[i].x;
  // Reported against the whole graph, as a plain solve would be.
  out.solve.initial_chi2 = initial_chi2;
  out.solve.final_chi2 = Chi2(graph);
  return out;
}

}  // namespace cairn
