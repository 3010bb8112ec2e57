#include "cairn/robust/outliers.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <map>
#include <set>
#include <unordered_map>
#include <stdexcept>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/robust/leverage.h"

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
  if (!(p > 0 && p < 1) || dof < 1) throw std::invalid_argument("ChiSquaredQuantile: bad arguments");
  // The survival function in closed form for an integer dof: a Poisson sum
  // (even dof), erfc and a half-integer series (odd dof).
  auto survival = [dof](double x) {
    const double h = x / 2;
    double sum = 0, term;
    if (dof % 2 == 0) {
      term = std::exp(-h);
      for (int i = 0; i < dof / 2; ++i) {
        sum += term;
        term *= h / (i + 1);
      }
      return sum;
    }
    sum = std::erfc(std::sqrt(h));
    term = std::exp(-h) * std::sqrt(h) / (std::sqrt(M_PI) / 2);  // h^(1/2) e^-h / Gamma(3/2)
    for (int i = 0; i < (dof - 1) / 2; ++i) {
      sum += term;
      term *= h / (i + 1.5);
    }
    return sum;
  };
  // The survival function falls from 1: bisect for survival(x) = 1 - p.
  double lo = 0, hi = dof + 10.0;
  while (survival(hi) > 1 - p) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = (lo + hi) / 2;
    (survival(mid) > 1 - p ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

double LoopClosureThreshold(double confidence, int dof, size_t loop_closures) {
  if (!(confidence > 0 && confidence < 1))
    throw std::invalid_argument("the confidence must lie in (0, 1)");
  const double n = static_cast<double>(std::max<size_t>(loop_closures, 1));
  return ChiSquaredQuantile(1 - (1 - confidence) / n, dof);
}

OutlierRejectionResult SolveRejectingOutliers(PoseGraph& graph, const GraphSolver& solve,
                                              const OutlierRejectionOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  OutlierRejectionResult out;
  const double initial_chi2 = Chi2(graph);
  std::vector<size_t> closures;
  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (graph.edges()[k].kind == EdgeKind::kLoopClosure) closures.push_back(k);
  const double c2 = options.threshold_chi2 > 0
                        ? options.threshold_chi2
                        : LoopClosureThreshold(options.confidence, graph.TangentSize(),
                                               closures.size());
  out.threshold_chi2 = c2;

  // The weighted problem: weights scale the loop closures' information; a
  // loop closure at weight 0, or outside the current stage, is left out
  // altogether (a negligible weight would still cost fill in the
  // factorisation: random wrong loop closures join far-apart poses).
  PoseGraph work = graph;  // its vertices hold the current estimate
  std::vector<double> w(closures.size(), 1.0);
  auto solve_weighted = [&](const std::vector<bool>& in, int iterations) {
    PoseGraph g(graph.dimension());
    for (const Vertex& v : work.vertices()) g.AddVertex(v.id, v.x, v.fixed);
    size_t next = 0;  // the next loop closure, in edge order
    for (size_t k = 0; k < graph.edges().size(); ++k) {
      Edge e = graph.edges()[k];
      if (next < closures.size() && closures[next] == k) {
        const size_t i = next++;
        if (!in[i] || !(w[i] > 0)) continue;
        e.information *= std::max(w[i], 1e-9);
      }
      g.AddEdge(e);
    }
    const SolveResult r = solve(g, iterations);
    for (size_t v = 0; v < g.vertices().size(); ++v) work.vertices()[v].x = g.vertices()[v].x;
    return r;
  };
  auto residuals = [&] {
    std::vector<double> r2(closures.size());
    for (size_t i = 0; i < closures.size(); ++i)
      r2[i] = EdgeChi2(work, graph.edges()[closures[i]]);  // unweighted, at work's estimate
    return r2;
  };
  std::vector<double> r2 = residuals();

  // GNC over the loop closures in `in`, from mu0 (<= 0: where every
  // residual is inside the surrogate's convex part).
  auto gnc = [&](const std::vector<bool>& in, double mu, const char* stage) {
    double r2_max = 0;
    for (size_t i = 0; i < closures.size(); ++i)
      if (in[i] && std::isfinite(r2[i])) r2_max = std::max(r2_max, r2[i]);
    if (mu <= 0) {
      if (!(r2_max > c2)) {
        for (size_t i = 0; i < closures.size(); ++i)
          if (in[i]) w[i] = 1;
        if (options.verbose) std::fprintf(stderr, "gnc (%s): every loop closure fits\n", stage);
        return;
      }
      mu = c2 / std::max(2 * r2_max - c2, 1e-12);
    }
    size_t count = 0;
    for (bool x : in) count += x;
    for (int round = 0; round < options.max_rounds; ++round) {
      const double lo = mu / (mu + 1) * c2, hi = (mu + 1) / mu * c2;
      double undecided = 0;
      size_t active = 0;
      for (size_t i = 0; i < closures.size(); ++i) {
        if (!in[i]) continue;
        if (!std::isfinite(r2[i]) || r2[i] >= hi) w[i] = 0;
        else if (r2[i] <= lo) w[i] = 1;
        else w[i] = std::sqrt(c2 / r2[i] * mu * (mu + 1)) - mu;
        undecided += w[i] * (1 - w[i]);
        active += w[i] > 0;
      }
      // Binary weights that the last solve has not changed: the surrogate
      // has become the truncated cost.
      if (round > 0 && undecided < 1e-6 * std::max<size_t>(1, count) && mu > 1) break;
      out.solve = solve_weighted(in, options.inner_iterations);
      ++out.rounds;
      r2 = residuals();
      if (options.verbose)
        std::fprintf(stderr,
                     "gnc (%s) round %d: mu %.3g, %zu of %zu loop closures weighed in, "
                     "sum w(1-w) %.3g, chi2 %.6g, %d iterations, %.2f s\n",
                     stage, round + 1, mu, active, count, undecided, out.solve.final_chi2,
                     out.solve.iterations, out.solve.time_s);
      mu *= options.mu_factor;
    }
  };

  const std::vector<bool> all(closures.size(), true);
  std::vector<bool> confirmed(closures.size(), false);
  size_t n_confirmed = 0;
  if (options.consistency_window > 0) {
    const std::vector<int> support =
        LocalLoopClosureSupport(graph, options.consistency_window, c2);
    for (size_t i = 0; i < closures.size(); ++i) n_confirmed += confirmed[i] = support[i] > 0;
    if (options.verbose)
      std::fprintf(stderr,
                   "local consistency: %zu of %zu loop closures agree with a neighbour within "
                   "%d ids\n",
                   n_confirmed, closures.size(), options.consistency_window);
  }
  if (n_confirmed > 0) {
    // The loop closures a neighbour confirms first, alone: least squares
    // from the starting estimate (GNC's convex start from a poor estimate,
    // e.g. odometry, can settle in a wrong basin), then GNC from there in
    // case a wrong one was confirmed. Their estimate is one the other wrong
    // loop closures have not bent. Then all loop closures, from that
    // estimate: mu starts where residuals beyond restart_chi2_factor c^2
    // weigh 0.
    const double restart = 1 / (options.restart_chi2_factor - 1);
    out.solve = solve_weighted(confirmed, 0);
    ++out.rounds;
    r2 = residuals();
    if (options.verbose)
      std::fprintf(stderr, "least squares on the %zu confirmed: chi2 %.6g, %d iterations, %.2f s\n",
                   n_confirmed, out.solve.final_chi2, out.solve.iterations, out.solve.time_s);
    gnc(confirmed, restart, "confirmed");
    // Again while the set of loop closures that weigh in changes: as the
    // estimate improves, good loop closures that did not fit come within
    // reach (a region that only they constrain can relax towards them).
    std::vector<bool> in_before;
    for (int pass = 0; pass < options.max_passes; ++pass) {
      gnc(all, restart, "all");
      std::vector<bool> in(closures.size());
      for (size_t i = 0; i < closures.size(); ++i) in[i] = w[i] >= 0.5 || r2[i] <= c2;
      if (in == in_before) break;
      in_before = in;
    }
  } else {
    gnc(all, 0, "all");
  }

  // The verdict: a loop closure stays if its weight is up or it now fits.
  std::vector<bool> rejected(graph.edges().size(), false);
  for (size_t i = 0; i < closures.size(); ++i)
    if (w[i] < 0.5 && !(r2[i] <= c2)) rejected[closures[i]] = true;
  // The graph without the rejected loop closures, at GNC's estimate.
  std::vector<size_t> kept;  // edges of `inliers` that are loop closures
  std::vector<size_t> origin;  // per edge of `inliers`, its index in `graph`
  auto inliers_graph = [&] {
    PoseGraph g(graph.dimension());
    for (const Vertex& v : work.vertices()) g.AddVertex(v.id, v.x, v.fixed);
    kept.clear();
    origin.clear();
    for (size_t k = 0; k < graph.edges().size(); ++k) {
      if (rejected[k]) continue;
      if (graph.edges()[k].kind == EdgeKind::kLoopClosure) kept.push_back(g.edges().size());
      origin.push_back(k);
      g.AddEdge(graph.edges()[k]);
    }
    return g;
  };
  PoseGraph inliers = inliers_graph();
  out.solve = solve(inliers, 0);
  if (options.verbose)
    std::fprintf(stderr, "without the %zu rejected: chi2 %.6g, %d iterations, %.2f s\n",
                 closures.size() - kept.size(), out.solve.final_chi2, out.solve.iterations,
                 out.solve.time_s);
  ++out.rounds;

  // Verification. GNC's weights are decided one loop closure at a time, at
  // the estimate: a wrong loop closure that the trajectory has bent to fit
  // looks like a good one there. Deleting it would release that bend, and the
  // deleted-residual statistic predicts by how much chi2 falls: more than c^2
  // and the truncated cost itself is lower without it (it then costs c^2).
  // The worst such loop closure goes, the rest is re-solved and checked again.
  std::vector<bool> verified_out(graph.edges().size(), false);
  auto verify = [&] {
    for (int round = 0; options.verify && round < options.max_verify_rounds; ++round) {
      if (!out.solve.usable) break;
      std::vector<double> gain;
      try {
        gain = DeletedResidualChi2(inliers, kept);
      } catch (const std::runtime_error& e) {
        if (options.verbose)
          std::fprintf(stderr, "verification skipped: %s\n", e.what());
        break;
      }
      const double bound = c2;
      // Of those over the bound, the one whose deletion releases most in the
      // rest of the graph (the fall beyond its own residual): good loop
      // closures near a bend have large residuals too, the wrong one holds it.
      size_t worst = kept.size();
      double worst_release = 0;
      for (size_t i = 0; i < kept.size(); ++i) {
        if (!(gain[i] > bound)) continue;
        const double release = gain[i] - EdgeChi2(inliers, inliers.edges()[kept[i]]);
        if (worst == kept.size() || release > worst_release) {
          worst = i;
          worst_release = release;
        }
      }
      if (worst == kept.size()) break;
      const Edge& e = inliers.edges()[kept[worst]];
      if (options.verbose)
        std::fprintf(stderr,
                     "verify: loop closure %lld-%lld fits (chi2 %.3g) but deleting it lowers chi2 "
                     "by %.4g > %.4g: rejected\n",
                     static_cast<long long>(e.from), static_cast<long long>(e.to),
                     EdgeChi2(inliers, e), gain[worst], bound);
      rejected[origin[kept[worst]]] = true;
      verified_out[origin[kept[worst]]] = true;
      ++out.verified;
      for (Vertex& v : work.vertices()) v.x = inliers.vertex(v.id).x;
      inliers = inliers_graph();
      out.solve = solve(inliers, 0);
      ++out.rounds;
      // Released from the bend, loop closures GNC rejected may fit again.
      size_t readmitted = 0;
      for (size_t k = 0; k < graph.edges().size(); ++k)
        if (rejected[k] && !verified_out[k] && EdgeChi2(inliers, graph.edges()[k]) <= c2) {
          rejected[k] = false;
          ++readmitted;
        }
      if (readmitted > 0) {
        if (options.verbose)
          std::fprintf(stderr, "verify: %zu rejected loop closures fit again: kept\n", readmitted);
        for (Vertex& v : work.vertices()) v.x = inliers.vertex(v.id).x;
        inliers = inliers_graph();
        out.solve = solve(inliers, 0);
        ++out.rounds;
      }
    }
  };
  verify();

  // Re-admission. A good loop closure that no neighbour confirms and that
  // the estimate of the confirmed ones left beyond GNC's reach stays out
  // above; at the final estimate, the innovation statistic
  // r^T (I + J Sigma J^T)^{-1} r (the rise of the optimal chi2 if it were
  // added, Sigma the exact joint covariance of its poses) tells whether the
  // graph could take it. Those within c^2 come back, the rest is re-solved
  // and verified again.
  for (int pass = 0; options.readmit && pass < options.max_passes; ++pass) {
    if (!out.solve.usable) break;
    std::vector<Edge> cand;
    std::vector<size_t> cand_k;
    for (size_t k = 0; k < graph.edges().size(); ++k) {
      if (!rejected[k] || verified_out[k]) continue;
      const double r2k = EdgeChi2(inliers, graph.edges()[k]);
      if (!(r2k <= options.readmit_reach * c2)) continue;
      cand.push_back(graph.edges()[k]);
      cand_k.push_back(k);
    }
    if (cand.empty()) break;
    std::vector<InnovationStat> stat;
    try {
      stat = InnovationChi2(inliers, cand);
    } catch (const std::runtime_error& e) {
      if (options.verbose) std::fprintf(stderr, "re-admission skipped: %s\n", e.what());
      break;
    }
    // The noise the kept graph shows, chi2 per degree of freedom (the
    // a-posteriori variance factor): when the information matrices are
    // looser than the residuals (intel's are, by two orders of magnitude),
    // a loop closure to a loosely held part of the graph can be bent into
    // place within c^2 whether it is right or not. The test is scaled down by
    // that factor, never up.
    const std::vector<bool> held = HeldConstant(inliers);
    const double variables =
        graph.TangentSize() * static_cast<double>(
            inliers.vertices().size() - std::count(held.begin(), held.end(), true));
    const double dof = graph.TangentSize() * static_cast<double>(inliers.edges().size()) - variables;
    const double factor = dof > 0 ? std::min(1.0, Chi2(inliers) / dof) : 1.0;
    const double bound = c2 * factor;
    size_t back = 0;
    for (size_t i = 0; i < cand.size(); ++i) {
      const bool ok = stat[i].chi2 <= bound;
      if (options.verbose)
        std::fprintf(stderr, "readmit? %lld-%lld chi2 %.4g innovation %.4g spread %.4g%s\n",
                     static_cast<long long>(cand[i].from), static_cast<long long>(cand[i].to),
                     EdgeChi2(inliers, cand[i]), stat[i].chi2, stat[i].spread, ok ? " yes" : "");
      if (ok) {
        rejected[cand_k[i]] = false;
        ++back;
      }
    }
    if (options.verbose)
      std::fprintf(stderr, "re-admission: %zu of %zu candidates within %.4g (variance factor %.3g)\n",
                   back, cand.size(), bound, factor);
    if (back == 0) break;
    for (Vertex& v : work.vertices()) v.x = inliers.vertex(v.id).x;
    inliers = inliers_graph();
    out.solve = solve(inliers, 0);
    ++out.rounds;
    verify();
  }

  for (size_t k = 0; k < graph.edges().size(); ++k)
    if (rejected[k]) out.rejected.emplace_back(graph.edges()[k].from, graph.edges()[k].to);
  auto& dst = graph.vertices();
  for (size_t i = 0; i < dst.size(); ++i) dst[i].x = inliers.vertices()[i].x;
  // Reported against the whole graph, as a plain solve would be.
  out.solve.initial_chi2 = initial_chi2;
  out.solve.final_chi2 = Chi2(graph);
  return out;
}

}  // namespace cairn

namespace cairn {
namespace {

// Poses as (t, w) tangent coordinates with right perturbations X Exp(d),
// first order: the adjoint of S^{-1}, which carries a perturbation on the
// right of X past S (X Exp(d) S = X S Exp(AdInv(S) d)).
Eigen::MatrixXd AdInverse(const SE2& s) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(3, 3);
  const Eigen::Matrix2d rt = s.rotation().transpose();
  a.topLeftCorner<2, 2>() = rt;
  a.topRightCorner<2, 1>() = rt * Eigen::Vector2d(-s.y(), s.x());  // R^T J t
  return a;
}
Eigen::MatrixXd AdInverse(const SE3& s) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(6, 6);
  const Eigen::Matrix3d rt = s.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d t = s.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  a.topLeftCorner<3, 3>() = rt;
  a.topRightCorner<3, 3>() = -rt * tx;
  a.bottomRightCorner<3, 3>() = rt;
  return a;
}
Eigen::VectorXd Log(const SE2& e) { return e.ToVector(); }
Eigen::VectorXd Log(const SE3& e) {
  Eigen::VectorXd v(6);
  v << e.translation(), QuaternionLog(e.rotation());
  return v;
}

template <typename Pose>
struct Measured {
  Pose z;
  Eigen::MatrixXd cov;  // of the right perturbation, (t, w) coordinates
  Measured Inverse() const {
    const Eigen::MatrixXd ad = AdInverse(z.Inverse());  // Ad(z)
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
      const Eigen::MatrixXd ad = AdInverse(s);
      cov += ad * f[k].cov * ad.transpose();
      s = f[k].z * s;
    }
    const Eigen::VectorXd e = Log(i.m.z.Inverse() * s);
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
  return graph.dimension() == 2 ? LocalSupport<SE2>(graph, window, threshold_chi2)
                                : LocalSupport<SE3>(graph, window, threshold_chi2);
}

}  // namespace cairn
