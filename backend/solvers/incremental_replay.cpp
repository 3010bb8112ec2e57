#include "cairn/solvers/incremental_replay.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "cairn/graph/chi2.h"
#include "cairn/graph/runtime.h"

namespace cairn {
namespace {

// Edges bucketed by the position (in id order) of the later of their poses.
struct ReplayPlan {
  std::vector<size_t> order;                 // vertex indices by id
  std::vector<std::vector<size_t>> edges_at;  // per position, edge indices in file order
};

ReplayPlan PlanReplay(const PoseGraph& graph) {
  const auto& vertices = graph.vertices();
  ReplayPlan plan;
  plan.order.resize(vertices.size());
  std::iota(plan.order.begin(), plan.order.end(), size_t{0});
  std::sort(plan.order.begin(), plan.order.end(),
            [&](size_t a, size_t b) { return vertices[a].id < vertices[b].id; });
  std::vector<size_t> rank(vertices.size());
  for (size_t k = 0; k < plan.order.size(); ++k) rank[plan.order[k]] = k;
  plan.edges_at.resize(vertices.size());
  const auto& edges = graph.edges();
  for (size_t e = 0; e < edges.size(); ++e) {
    size_t at = rank[graph.VertexIndex(edges[e].from)];
    if (!edges[e].IsPrior()) at = std::max(at, rank[graph.VertexIndex(edges[e].to)]);
    plan.edges_at[at].push_back(e);
  }
  return plan;
}

// Where a robot would put the new pose: an older pose's estimate composed
// with a measurement between them (odometry first), else the file's value.
template <typename Pose>
Pose FirstGuess(const PoseGraph& source, const IncrementalOptimizer& opt, const Vertex& v,
                const std::vector<size_t>& edges) {
  Edge chosen;  // a copy: the graph gives its edges by value
  const Edge* best = nullptr;
  for (size_t e : edges) {
    const Edge edge = source.edges()[e];
    if (!edge.JoinsPoses() || edge.from == edge.to) continue;
    if (!best || (edge.kind == EdgeKind::kOdometry && best->kind != EdgeKind::kOdometry)) {
      chosen = edge;
      best = &chosen;
    }
  }
  auto pose_of = [&](int64_t id) {
    if constexpr (std::is_same_v<Pose, SE2>) {
      return opt.PoseSE2(id);
    } else {
      return opt.PoseSE3(id);
    }
  };
  if (!best || v.fixed) {
    if constexpr (std::is_same_v<Pose, SE2>) {
      return ToSE2(v.x);
    } else {
      return ToSE3(v.x);
    }
  }
  Pose z;
  if constexpr (std::is_same_v<Pose, SE2>) {
    z = ToSE2(best->z);
  } else {
    z = ToSE3(best->z);
  }
  return best->to == v.id ? pose_of(best->from) * z : pose_of(best->to) * z.Inverse();
}

void FeedPose(const PoseGraph& source, IncrementalOptimizer& opt, const Vertex& v,
              const std::vector<size_t>& edges) {
  if (source.dimension() == 2) {
    opt.AddPose(v.id, FirstGuess<SE2>(source, opt, v, edges), v.fixed);
  } else {
    opt.AddPose(v.id, FirstGuess<SE3>(source, opt, v, edges), v.fixed);
  }
  for (size_t e : edges) opt.AddEdge(source.edges()[e]);
}

void Step(IncrementalOptimizer& opt, ReplayMode mode, ReplayResult* result) {
  switch (mode) {
    case ReplayMode::kPartial: result->step_updates.back() = opt.Update(); break;
    case ReplayMode::kGaussNewton: opt.Optimize(SolverKind::kGaussNewton); break;
    case ReplayMode::kCeres: opt.Optimize(SolverKind::kCeres); break;
  }
}

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

ReplayResult::Counts ReplayResult::Count() const {
  Counts c;
  for (size_t k = 0; k < step_updates.size(); ++k) {
    const UpdateResult& u = step_updates[k];
    c.whole_solves += u.exact;
    c.relinearized += static_cast<size_t>(u.relinearized_vertices);
    c.retried += static_cast<size_t>(u.retried);
    if (!u.refactorized) continue;
    ++c.refactorizations;
    ++c.refactorizations_by[static_cast<size_t>(u.reason)];
    c.refactorization_steps_s += step_s[k];
  }
  return c;
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(q * static_cast<double>(values.size()));
  const size_t k = rank < 1 ? 0 : static_cast<size_t>(rank) - 1;
  return values[std::min(k, values.size() - 1)];
}

ReplayResult Replay(const PoseGraph& graph, const ReplayOptions& options) {
  if (graph.HasLandmarks()) throw std::invalid_argument("replay: the graph has landmarks");
  if (options.every < 1) throw std::invalid_argument("replay: every must be >= 1");
  const ReplayPlan plan = PlanReplay(graph);
  IncrementalOptimizer opt(graph.dimension(), options.incremental);
  for (const auto& [id, offset] : graph.offsets()) opt.SetOffset(id, offset);
  ReplayResult result;
  result.poses = plan.order.size();
  result.edges = graph.edges().size();
  const auto all = std::chrono::steady_clock::now();
  auto step_start = all;
  double cpu_start = ProcessCpuSeconds();
  for (size_t k = 0; k < plan.order.size(); ++k) {
    FeedPose(graph, opt, graph.vertices()[plan.order[k]], plan.edges_at[k]);
    const bool last = k + 1 == plan.order.size();
    if (!last && (k + 1) % static_cast<size_t>(options.every) != 0) continue;
    // A pose no edge has reached yet is no unknown: nothing to solve.
    result.step_poses.push_back(k + 1);
    result.step_updates.emplace_back();
    if (!opt.graph().edges().empty()) Step(opt, options.mode, &result);
    const auto now = std::chrono::steady_clock::now();
    result.step_s.push_back(std::chrono::duration<double>(now - step_start).count());
    step_start = now;
    const double cpu_now = ProcessCpuSeconds();
    result.step_cpu_s.push_back(cpu_now - cpu_start);
    cpu_start = cpu_now;
    if (options.progress) options.progress(k + 1, plan.order.size());
  }
  result.total_s = Seconds(all);
  result.replay_chi2 = Chi2(opt.graph());
  const auto final_start = std::chrono::steady_clock::now();
  const SolverKind exact =
      options.mode == ReplayMode::kCeres ? SolverKind::kCeres : SolverKind::kGaussNewton;
  result.final_chi2 = opt.graph().edges().empty() ? 0 : opt.Optimize(exact).final_chi2;
  result.final_time_s = Seconds(final_start);
  return result;
}

}  // namespace cairn
