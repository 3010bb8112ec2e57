#include "cairn/robust/pairwise_consistency.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <random>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "cairn/graph/geometry.h"
#include "cairn/linear/parallel.h"

namespace cairn {
namespace {

// Ad(x): exp(Ad(x) d) x = x exp(d), to first order in the solvers' chart.
template <typename Pose>
auto Ad(const Pose& x) {
  return InverseAdjoint(x.Inverse());
}

// A measurement's covariance in its right perturbation's (t, w) coordinates.
template <int D>
Eigen::Matrix<double, D, D> CovarianceOf(const Edge& e) {
  if constexpr (D == 3) {
    return e.information.topLeftCorner<3, 3>().inverse();
  } else {
    // The factor's rotation error is the quaternion's vector part, w / 2.
    Vector6d scale;
    scale << 1, 1, 1, 2, 2, 2;
    return scale.asDiagonal() * e.information.inverse() * scale.asDiagonal();
  }
}

}  // namespace

// Per pose id: its odometry chain (a run of consecutive ids), the chain's
// product of steps up to it, P, and the covariance of P's left perturbation
// accumulated along the chain, W = sum over steps m of Ad(P_{m+1}) S_m
// Ad(P_{m+1})^T. The path a -> c along one chain is P_a^-1 P_c, and its
// perturbation is the one of W_c - W_a, so any path costs O(1).
struct CycleTester::Impl {
  virtual ~Impl() = default;
  virtual double PairChi2(size_t i, size_t j) const = 0;
  std::vector<std::pair<int64_t, int64_t>> ends;
};

namespace {

template <typename Pose, int D>
struct Chains final : CycleTester::Impl {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  struct Node {
    size_t chain;
    Pose p;
    Mat w;
  };
  struct Closure {
    int64_t a, b;  // a < b
    Pose z;        // a -> b
    Mat cov;
  };
  std::unordered_map<int64_t, Node> node;
  std::vector<Closure> closures;

  static Mat Flip(const Pose& z, const Mat& cov) {
    const Mat ad = Ad(z);
    return ad * cov * ad.transpose();
  }

  explicit Chains(const PoseGraph& graph) {
    std::unordered_map<int64_t, std::pair<Pose, Mat>> step;  // id -> id + 1
    for (const Edge& e : graph.edges()) {
      if (!e.JoinsPoses()) continue;
      const Pose z = ToPose<Pose>(e.z);
      const Mat cov = CovarianceOf<D>(e);
      if (e.kind == EdgeKind::kOdometry && e.to == e.from + 1) {
        step.emplace(e.from, std::make_pair(z, cov));
      } else if (e.kind == EdgeKind::kOdometry && e.from == e.to + 1) {
        step.emplace(e.to, std::make_pair(z.Inverse(), Flip(z, cov)));
      } else if (e.kind == EdgeKind::kLoopClosure) {
        if (e.from < e.to) closures.push_back({e.from, e.to, z, cov});
        else closures.push_back({e.to, e.from, z.Inverse(), Flip(z, cov)});
        ends.emplace_back(closures.back().a, closures.back().b);
      }
    }
    std::vector<int64_t> ids;
    for (const Vertex& v : graph.vertices()) ids.push_back(v.id);
    std::sort(ids.begin(), ids.end());
    size_t chain = 0;
    for (size_t k = 0; k < ids.size(); ++k) {
      const auto it = k > 0 && ids[k] == ids[k - 1] + 1 ? step.find(ids[k - 1]) : step.end();
      if (it == step.end()) {
        node.emplace(ids[k], Node{++chain, Pose(), Mat::Zero()});
        continue;
      }
      const Node& prev = node.at(ids[k - 1]);
      const Pose p = prev.p * it->second.first;
      const Mat ad = Ad(p);
      node.emplace(ids[k], Node{chain, p, Mat(prev.w + ad * it->second.second * ad.transpose())});
    }
  }

  // The accumulated covariance over the steps between ids lo and hi.
  Mat Span(int64_t lo, int64_t hi) const { return node.at(hi).w - node.at(lo).w; }

  // Closure i against closure j's ends taken as (aj, bj) with measurement
  // zj: the cycle z_i^-1 P_ai^-1 P_aj z_j P_bj^-1 P_bi = G exp(delta) H.
  double Cycle(const Closure& i, int64_t aj, int64_t bj, const Pose& zj, const Mat& covj) const {
    const Node &nai = node.at(i.a), &nbi = node.at(i.b), &naj = node.at(aj), &nbj = node.at(bj);
    const Pose m = naj.p * zj * nbj.p.Inverse();
    const Pose h = m * nbi.p;
    const Vec r = LogMap(i.z.Inverse() * nai.p.Inverse() * h);
    const Mat adm = Ad(m);
    const int64_t alo = std::min(i.a, aj), ahi = std::max(i.a, aj);
    const int64_t blo = std::min(i.b, bj), bhi = std::max(i.b, bj);
    const Mat wa = Span(alo, ahi), wb = Span(blo, bhi);
    // Steps on both paths enter once, with both paths' coefficients.
    const int64_t olo = std::max(alo, blo), ohi = std::min(ahi, bhi);
    Mat wo = Mat::Zero();
    if (nai.chain == nbi.chain && olo < ohi) wo = Span(olo, ohi);
    const double sa = aj > i.a ? 1 : -1, sb = i.b > bj ? 1 : -1;
    const Mat k = sa * Mat::Identity() + sb * adm;
    const Mat adj = Ad(naj.p * zj), adi = Ad(nai.p * i.z);
    Mat cov = wa - wo + adm * (wb - wo) * adm.transpose() + k * wo * k.transpose() +
              adj * covj * adj.transpose() + adi * i.cov * adi.transpose();
    const Mat back = InverseAdjoint(h);
    cov = back * cov * back.transpose();
    const Eigen::LDLT<Mat> ldlt(cov);
    if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
    return r.dot(ldlt.solve(r));
  }

  bool Joined(int64_t x, int64_t y) const { return node.at(x).chain == node.at(y).chain; }

  double PairChi2(size_t i, size_t j) const override {
    const Closure &ci = closures[i], &cj = closures[j];
    const bool straight = Joined(ci.a, cj.a) && Joined(ci.b, cj.b);
    const bool crossed = Joined(ci.a, cj.b) && Joined(ci.b, cj.a);
    const int64_t ls = std::abs(ci.a - cj.a) + std::abs(ci.b - cj.b);
    const int64_t lc = std::abs(ci.a - cj.b) + std::abs(ci.b - cj.a);
    if (straight && (!crossed || ls <= lc)) return Cycle(ci, cj.a, cj.b, cj.z, cj.cov);
    if (crossed) return Cycle(ci, cj.b, cj.a, cj.z.Inverse(), Flip(cj.z, cj.cov));
    return std::numeric_limits<double>::quiet_NaN();
  }
};

}  // namespace

CycleTester::CycleTester(const PoseGraph& graph) : impl_(nullptr) {
  RequireNoLandmarks(graph, "the pairwise consistency check");
  if (graph.dimension() == 2) impl_ = new Chains<SE2, 3>(graph);
  else impl_ = new Chains<SE3, 6>(graph);
}

CycleTester::~CycleTester() { delete impl_; }

size_t CycleTester::size() const { return impl_->ends.size(); }

double CycleTester::PairChi2(size_t i, size_t j) const { return impl_->PairChi2(i, j); }

std::pair<int64_t, int64_t> CycleTester::Ends(size_t i) const { return impl_->ends[i]; }

}  // namespace cairn

namespace cairn {
namespace {

// Conflicts as adjacency lists: which tested pairs are inconsistent.
struct ConflictGraph {
  std::vector<std::vector<uint32_t>> adj;
  size_t tested = 0, conflicts = 0;
};

struct TestedPair {
  uint32_t i, j;
  float chi2;
  bool near;
};

// The shortest odometry the cycle of i and j takes, in steps.
int64_t Span(const CycleTester& t, size_t i, size_t j) {
  const auto [ai, bi] = t.Ends(i);
  const auto [aj, bj] = t.Ends(j);
  return std::min(std::abs(ai - aj) + std::abs(bi - bj), std::abs(ai - bj) + std::abs(bi - aj));
}

using Buckets = std::map<std::pair<int64_t, int64_t>, std::vector<uint32_t>>;

// The pairs loop closures [begin, end) test (each against later ones near
// it, and random partners), in order.
std::vector<TestedPair> PairsFrom(const CycleTester& t, const ConsistentSetOptions& o,
                                  const Buckets& buckets, size_t begin, size_t end) {
  const size_t n = t.size();
  const int64_t w = std::max(o.window, 1), r = std::max<int64_t>(o.reach, w);
  std::vector<TestedPair> pairs;
  auto test = [&](size_t i, size_t j) {
    pairs.push_back({static_cast<uint32_t>(i), static_cast<uint32_t>(j),
                     static_cast<float>(t.PairChi2(i, j)), Span(t, i, j) <= 2 * w});
  };
  std::vector<uint32_t> seen(n, UINT32_MAX);  // the i that last tested j
  std::vector<uint32_t> medium;
  for (size_t i = begin; i < end; ++i) {
    const auto [a, b] = t.Ends(i);
    medium.clear();
    for (int64_t da = -1; da <= 1; ++da)
      for (int64_t db = -1; db <= 1; ++db) {
        const auto it = buckets.find({a / r + da, b / r + db});
        if (it == buckets.end()) continue;
        for (uint32_t j : it->second) {
          const auto [aj, bj] = t.Ends(j);
          if (j <= i || std::abs(aj - a) > r || std::abs(bj - b) > r) continue;
          if (std::abs(aj - a) > w || std::abs(bj - b) > w) {
            medium.push_back(j);
            continue;
          }
          seen[j] = static_cast<uint32_t>(i);
          test(i, j);
        }
      }
    const size_t stride = std::max<size_t>(1, medium.size() / std::max(o.medium, 1));
    for (size_t k = 0; k < medium.size() && o.medium > 0; k += stride) {
      seen[medium[k]] = static_cast<uint32_t>(i);
      test(i, medium[k]);
    }
    std::mt19937_64 rng(o.seed * 1000003 + i);
    std::uniform_int_distribution<size_t> pick(0, n - 1);
    for (int k = 0; k < o.partners && n > 1; ++k) {
      const size_t j = pick(rng);
      if (j == i || seen[j] == i) continue;
      seen[j] = static_cast<uint32_t>(i);
      test(i, j);
    }
  }
  return pairs;
}

// Every pair with both ends within `window` ids; of the pairs with both ends
// within `reach` ids, `medium` at most (evenly through them); and `partners`
// random others per loop closure. Cycles of a few hundred poses are where an
// aliased group meets the good loop closures of the places it claims to
// join, with odometry still certain enough to tell; random partners are
// mostly thousands of poses away. Found through buckets of reach x reach ids.
// Threads take contiguous ranges of loop closures, whose pairs are joined in
// order: the result does not depend on the thread count.
std::vector<TestedPair> SparsePairs(const CycleTester& t, const ConsistentSetOptions& o) {
  const size_t n = t.size();
  const int64_t w = std::max(o.window, 1), r = std::max<int64_t>(o.reach, w);
  Buckets buckets;
  for (size_t i = 0; i < n; ++i) {
    const auto [a, b] = t.Ends(i);
    buckets[{a / r, b / r}].push_back(static_cast<uint32_t>(i));
  }
  const int threads = o.threads > 0 ? o.threads
                                    : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  ThreadPool pool(threads);
  const size_t parts = static_cast<size_t>(pool.size());
  std::vector<std::vector<TestedPair>> chunks(parts);
  // ParallelFor's chunks are [k n / parts, (k + 1) n / parts).
  pool.ParallelFor(n, [&](size_t begin, size_t end) {
    size_t k = 0;
    while (k + 1 < parts && n * (k + 1) / parts <= begin) ++k;
    chunks[k] = PairsFrom(t, o, buckets, begin, end);
  }, 16);
  std::vector<TestedPair> pairs;
  for (auto& c : chunks) pairs.insert(pairs.end(), c.begin(), c.end());
  return pairs;
}

std::vector<TestedPair> AllPairs(const CycleTester& t, int window) {
  std::vector<TestedPair> pairs;
  for (size_t i = 0; i < t.size(); ++i)
    for (size_t j = i + 1; j < t.size(); ++j)
      pairs.push_back({static_cast<uint32_t>(i), static_cast<uint32_t>(j),
                       static_cast<float>(t.PairChi2(i, j)), Span(t, i, j) <= 2 * window});
  return pairs;
}

// The noise the short cycles show against their covariances (the variance
// factor), from the median of their chi2 over chi2's median: robust to the
// wrong pairs among them, and never above 1. Information matrices far looser
// than the noise (intel's) would otherwise let a wrong loop closure pass a
// cycle of loose odometry.
double CycleVarianceFactor(const std::vector<TestedPair>& pairs, int dof) {
  std::vector<float> near;
  for (const TestedPair& p : pairs)
    if (p.near && std::isfinite(p.chi2)) near.push_back(p.chi2);
  if (near.size() < 20) return 1;
  std::nth_element(near.begin(), near.begin() + near.size() / 2, near.end());
  // The medians of chi2 with 3 and 6 degrees of freedom.
  const double median = dof == 3 ? 2.365974 : 5.348121;
  return std::clamp(near[near.size() / 2] / median, 1e-3, 1.0);
}

// NaN (no odometry between the ends, a degenerate covariance) is no
// evidence against a pair.
ConflictGraph Conflicts(size_t n, const std::vector<TestedPair>& pairs, double c2) {
  ConflictGraph g;
  g.adj.resize(n);
  g.tested = pairs.size();
  for (const TestedPair& p : pairs)
    if (p.chi2 > c2) {
      g.adj[p.i].push_back(p.j);
      g.adj[p.j].push_back(p.i);
      ++g.conflicts;
    }
  return g;
}

// Greedy: the loop closure in most conflicts leaves, its neighbours' counts
// fall, until no conflict is left among those that stay.
std::vector<bool> GreedyWithoutConflicts(const ConflictGraph& g) {
  const size_t n = g.adj.size();
  std::vector<bool> in(n, true);
  std::vector<size_t> degree(n);
  std::priority_queue<std::pair<size_t, uint32_t>> queue;
  for (size_t i = 0; i < n; ++i) {
    degree[i] = g.adj[i].size();
    if (degree[i] > 0) queue.emplace(degree[i], static_cast<uint32_t>(i));
  }
  while (!queue.empty()) {
    const auto [d, i] = queue.top();
    queue.pop();
    if (!in[i] || d != degree[i] || d == 0) continue;  // stale
    in[i] = false;
    for (uint32_t j : g.adj[i])
      if (in[j] && --degree[j] > 0) queue.emplace(degree[j], j);
  }
  return in;
}

// The maximum clique of the consistency graph (the complement of the
// conflicts), n <= 64, by branch and bound with a colouring bound.
struct CliqueSearch {
  std::vector<uint64_t> agree;  // per vertex, the vertices consistent with it
  uint64_t best = 0;
  int best_size = 0;

  void Expand(uint64_t clique, int size, uint64_t candidates) {
    if (candidates == 0) {
      if (size > best_size) best = clique, best_size = size;
      return;
    }
    // Greedy colouring of the candidates: a clique takes one vertex per colour.
    std::vector<std::pair<int, int>> order;  // (colour, vertex)
    uint64_t left = candidates;
    for (int colour = 1; left; ++colour) {
      uint64_t q = left;
      while (q) {
        const int v = __builtin_ctzll(q);
        q &= ~(uint64_t{1} << v) & ~agree[v];
        left &= ~(uint64_t{1} << v);
        order.emplace_back(colour, v);
      }
    }
    for (size_t k = order.size(); k-- > 0;) {
      if (size + order[k].first <= best_size) return;
      const int v = order[k].second;
      Expand(clique | (uint64_t{1} << v), size + 1, candidates & agree[v]);
      candidates &= ~(uint64_t{1} << v);
    }
  }
};

std::vector<bool> ExactMaximumClique(const ConflictGraph& g) {
  const size_t n = g.adj.size();
  CliqueSearch s;
  const uint64_t everyone = n == 64 ? ~uint64_t{0} : (uint64_t{1} << n) - 1;
  s.agree.assign(n, everyone);
  for (size_t i = 0; i < n; ++i) {
    s.agree[i] &= ~(uint64_t{1} << i);
    for (uint32_t j : g.adj[i]) s.agree[i] &= ~(uint64_t{1} << j);
  }
  s.Expand(0, 0, everyone);
  std::vector<bool> in(n);
  for (size_t i = 0; i < n; ++i) in[i] = (s.best >> i) & 1;
  return in;
}

}  // namespace

ConsistentSet MaximumConsistentSet(const PoseGraph& graph, const ConsistentSetOptions& options) {
  if (!(options.threshold_chi2 > 0))
    throw std::invalid_argument("the pairwise consistency threshold must be positive");
  const CycleTester tester(graph);
  ConsistentSet out;
  out.exact = tester.size() <= std::min<size_t>(options.exact_limit, 64);
  const std::vector<TestedPair> pairs =
      out.exact ? AllPairs(tester, options.window) : SparsePairs(tester, options);
  out.variance_factor =
      options.scale_by_variance ? CycleVarianceFactor(pairs, graph.TangentSize()) : 1.0;
  const ConflictGraph g =
      Conflicts(tester.size(), pairs, options.threshold_chi2 * out.variance_factor);
  out.tested_pairs = g.tested;
  out.conflicts = g.conflicts;
  out.in = out.exact ? ExactMaximumClique(g) : GreedyWithoutConflicts(g);
  out.supported.assign(tester.size(), false);
  const double c2 = options.threshold_chi2 * out.variance_factor;
  for (const TestedPair& p : pairs)
    if (p.near && p.chi2 <= c2) out.supported[p.i] = out.supported[p.j] = true;
  return out;
}

}  // namespace cairn
