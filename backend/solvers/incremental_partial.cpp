#include "cairn/solvers/incremental_partial.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>
#include <stdexcept>

#include "cairn/graph/chi2.h"
#include "cairn/graph/runtime.h"
#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholesky_update.h"
#include "cairn/linear/cholmod_common.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"

namespace cairn {

const char* ToString(RebuildReason reason) {
  switch (reason) {
    case RebuildReason::kNone: return "none";
    case RebuildReason::kStart: return "start";
    case RebuildReason::kRoom: return "room";
    case RebuildReason::kFill: return "fill";
    case RebuildReason::kGauge: return "gauge";
    case RebuildReason::kRefused: return "refused";
  }
  return "?";
}

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Columns of an update or downdate C, and where each starts in the factor.
struct PartialUpdater::Columns {
  std::vector<int> p{0}, i;
  std::vector<double> x;
  int k = 0;
  void Push(int row, double value) {
    i.push_back(row);
    x.push_back(value);
  }
  void Close() {
    p.push_back(static_cast<int>(i.size()));
    ++k;
  }
  int First(int c) const { return i[p[c]]; }
};

PartialUpdater::PartialUpdater(PoseGraph* graph, const ceres::Manifold* manifold,
                               const ceres::LossFunction* loop_loss,
                               const PartialUpdateOptions& options)
    : graph_(graph),
      manifold_(manifold),
      loop_loss_(loop_loss),
      relinearize_threshold_(options.relinearize_threshold),
      wildfire_threshold_(options.wildfire_threshold),
      reserve_(options.reserve_poses),
      fill_bound_(options.fill_bound),
      relinearize_budget_(options.relinearize_budget),
      fill_fraction_(options.fill_fraction),
      d_(graph->TangentSize()),
      p_(graph->ParameterSize()),
      stride_(d_ * (2 * d_ + 1)),
      factor_(std::make_unique<UpdatableCholesky>()) {}

PartialUpdater::~PartialUpdater() = default;

bool PartialUpdateOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* why) {
    if (error) *error = why;
    return false;
  };
  // Written so that NaN fails too.
  if (!(relinearize_threshold >= 0)) return fail("relinearize_threshold must be a number >= 0");
  if (!(wildfire_threshold >= 0)) return fail("wildfire_threshold must be a number >= 0");
  if (reserve_poses < 1) return fail("reserve_poses must be >= 1");
  if (relinearize_budget < 1) return fail("relinearize_budget must be >= 1");
  if (fill_bound < 0) return fail("fill_bound must be >= 0");
  if (!(fill_fraction >= 0)) return fail("fill_fraction must be a number >= 0");
  return true;
}

bool PartialUpdater::Covers(const PoseGraph& graph) {
  if (graph.HasLandmarks()) return false;
  const GraphGauge gauge = ComputeGauge(graph);
  if (!gauge.undetermined.empty()) return false;
  return std::none_of(gauge.rotation_held.begin(), gauge.rotation_held.end(),
                      [](bool b) { return b; });
}

void PartialUpdater::Linearize(size_t e) {
  const Edge& edge = graph_->edges()[e];
  const int nb = edge.IsPrior() ? 1 : 2;
  const double* params[2] = {LinPoint(graph_->VertexIndex(edge.from)), nullptr};
  if (nb == 2) params[1] = LinPoint(graph_->VertexIndex(edge.to));
  // Room for the largest pose blocks (3D: 6 x 7 ambient, 7 x 6 plus): no
  // allocation per edge, which re-linearising thousands at once would pay.
  double ambient[2][6 * 7], plus[7 * 6], residual[6];
  double* jacobians[2] = {ambient[0], ambient[1]};
  if (!cost_[e]->Evaluate(params, residual, jacobians))
    throw std::runtime_error("an edge's residual could not be evaluated");
  Eigen::Map<RowMatrix> j(&jr_[e * stride_], d_, 2 * d_);
  j.setZero();
  for (int k = 0; k < nb; ++k) {
    manifold_->PlusJacobian(params[k], plus);
    j.middleCols(k * d_, d_).noalias() = Eigen::Map<const RowMatrix>(ambient[k], d_, p_) *
                                         Eigen::Map<const RowMatrix>(plus, p_, d_);
  }
  Eigen::Map<Eigen::VectorXd> r(&jr_[e * stride_ + 2 * d_ * d_], d_);
  r = Eigen::Map<const Eigen::VectorXd>(residual, d_);
  // A robust loss enters as its weight at the linearisation point (IRLS):
  // re-linearising the edge re-weights it.
  if (loop_loss_ && edge.kind == EdgeKind::kLoopClosure) {
    double rho[3];
    loop_loss_->Evaluate(r.squaredNorm(), rho);
    const double w = std::sqrt(std::max(rho[1], 0.0));
    j *= w;
    r *= w;
  }
}

void PartialUpdater::AppendColumns(size_t e, Columns* c) const {
  const Edge& edge = graph_->edges()[e];
  std::pair<int, int> ends[2];  // (block, which end), by block
  int count = 0;
  const int a = slot_[graph_->VertexIndex(edge.from)];
  if (a >= 0) ends[count++] = {a, 0};
  if (!edge.IsPrior()) {
    const int b = slot_[graph_->VertexIndex(edge.to)];
    if (b >= 0) ends[count++] = {b, 1};
  }
  if (count == 2 && ends[1].first < ends[0].first) std::swap(ends[0], ends[1]);
  const double* j = &jr_[e * stride_];
  const double* r = j + 2 * d_ * d_;
  for (int t = 0; t < d_; ++t) {
    for (int k = 0; k < count; ++k)
      for (int col = 0; col < d_; ++col)
        c->Push(ends[k].first * d_ + col, j[t * 2 * d_ + ends[k].second * d_ + col]);
    c->Push(rhs_, r[t]);
    c->Close();
  }
}

// The factors invert quaternions by conjugation, right only for unit ones.
void PartialUpdater::NormalizeRotation(Vertex& v) const {
  if (d_ == 6) Eigen::Map<Eigen::Quaterniond>(v.x.data() + 3).normalize();
}

int PartialUpdater::Find(int v) {
  while (uf_[v] != v) v = uf_[v] = uf_[uf_[v]];
  return v;
}

void PartialUpdater::ComputeComponents() {
  const auto& vertices = graph_->vertices();
  const int nv = static_cast<int>(vertices.size());
  uf_.resize(nv);
  for (int v = 0; v < nv; ++v) uf_[v] = v;
  touched_.assign(nv, false);
  anchored_.assign(nv, 0);
  min_id_.assign(nv, 0);
  for (const Edge& e : graph_->edges()) {
    const int a = static_cast<int>(graph_->VertexIndex(e.from));
    touched_[a] = true;
    if (e.IsPrior()) continue;
    const int b = static_cast<int>(graph_->VertexIndex(e.to));
    touched_[b] = true;
    const int ra = Find(a), rb = Find(b);
    if (ra != rb) uf_[ra] = rb;
  }
  for (int v = 0; v < nv; ++v) min_id_[v] = -1;
  for (int v = 0; v < nv; ++v) {
    if (!touched_[v]) continue;
    const int r = Find(v);
    if (vertices[v].fixed) anchored_[r] = 1;
    if (min_id_[r] < 0 || vertices[v].id < vertices[min_id_[r]].id) min_id_[r] = v;
  }
  for (const Edge& e : graph_->edges())
    if (e.IsPrior()) anchored_[Find(static_cast<int>(graph_->VertexIndex(e.from)))] = 1;
}

// False when the edge may move the gauge (a prior, a FIX pose, two
// components joined, a new lowest id): the held poses are then recomputed
// with a fresh factorisation. Otherwise records the poses it joins.
bool PartialUpdater::TakeInGauge(const Edge& e) {
  if (e.IsPrior() || e.IsLandmark()) return false;
  const int nv = static_cast<int>(graph_->vertices().size());
  for (int v = static_cast<int>(uf_.size()); v < nv; ++v) {
    uf_.push_back(v);
    touched_.push_back(false);
    anchored_.push_back(0);
    min_id_.push_back(v);
  }
  const int a = static_cast<int>(graph_->VertexIndex(e.from));
  const int b = static_cast<int>(graph_->VertexIndex(e.to));
  const auto& vertices = graph_->vertices();
  if ((!touched_[a] && vertices[a].fixed) || (!touched_[b] && vertices[b].fixed)) return false;
  if (!touched_[a] && !touched_[b]) return false;  // a new component: it needs a gauge
  if (touched_[a] && touched_[b]) return Find(a) == Find(b);
  const int fresh = touched_[a] ? b : a, old = Find(touched_[a] ? a : b);
  if (!anchored_[old] && vertices[fresh].id < vertices[min_id_[old]].id) return false;
  touched_[fresh] = true;
  uf_[fresh] = old;
  return true;
}

void PartialUpdater::AddEdgeToState(size_t e) {
  const Edge& edge = graph_->edges()[e];
  cost_.resize(std::max(cost_.size(), e + 1));
  if (!cost_[e]) cost_[e].reset(MakeCostFunction(*graph_, edge));
  jr_.resize(std::max(jr_.size(), (e + 1) * stride_));
  edges_of_[graph_->VertexIndex(edge.from)].push_back(static_cast<int>(e));
  if (!edge.IsPrior()) edges_of_[graph_->VertexIndex(edge.to)].push_back(static_cast<int>(e));
}


namespace {

// AMD on the variables' block graph, with the most recent poses constrained
// last (CAMD): the next poses' odometry then reaches only the top of the
// elimination tree, as iSAM2 keeps its newest variables at the root.
std::vector<int> RecentLastOrder(int m, const std::vector<std::vector<int>>& neighbours) {
  BlockPattern pattern;
  pattern.bp.push_back(0);
  for (int b = 0; b < m; ++b) {
    std::vector<int> col = neighbours[b];
    col.push_back(b);
    std::sort(col.begin(), col.end());
    col.erase(std::unique(col.begin(), col.end()), col.end());
    for (int r : col)
      if (r <= b) pattern.bi.push_back(r);
    pattern.bp.push_back(static_cast<int>(pattern.bi.size()));
  }
  pattern.first.resize(m + 1);
  for (int b = 0; b <= m; ++b) pattern.first[b] = b;
  CholmodCommon common;
  std::vector<int> order(m + 1);
  cholmod_sparse* graph = BlockGraph(pattern, common.get());
  constexpr int kRecent = 8;
  std::vector<int> member(m + 1, 0);
  // (CAMD needs both sets non-empty.)
  if (m > 2 * kRecent)
    for (int b = m - kRecent; b < m; ++b) member[b] = 1;
  const bool ok =
      graph && cholmod_camd(graph, nullptr, 0, member.data(), order.data(), common.get());
  if (graph) cholmod_free_sparse(&graph, common.get());
  if (!ok)
    for (int b = 0; b < m; ++b) order[b] = b;
  order.resize(m);
  return order;
}

}  // namespace

void PartialUpdater::PlaceVariables(const std::vector<bool>& held) {
  const auto& edges = graph_->edges();
  const size_t nv = graph_->vertices().size();
  std::vector<int> local(nv, -1), variables;
  for (size_t v = 0; v < nv; ++v)
    if (touched_[v] && !held[v]) {
      local[v] = static_cast<int>(variables.size());
      variables.push_back(static_cast<int>(v));
    }
  const int m = static_cast<int>(variables.size());
  std::vector<std::vector<int>> neighbours(m);
  for (const Edge& e : edges) {
    if (e.IsPrior()) continue;
    const int a = local[graph_->VertexIndex(e.from)], b = local[graph_->VertexIndex(e.to)];
    if (a < 0 || b < 0 || a == b) continue;
    neighbours[a].push_back(b);
    neighbours[b].push_back(a);
  }
  const std::vector<int> order = RecentLastOrder(m, neighbours);
  used_ = m;
  // Room in proportion to the graph too: a fresh factorisation costs what
  // the graph holds, and is then paid once per that many poses.
  cap_ = m + std::max(reserve_, m / 20);
  n_ = cap_ * d_;
  rhs_ = n_;
  slot_.assign(nv, -1);
  for (size_t v = 0; v < nv; ++v)
    if (touched_[v] && held[v]) slot_[v] = -2;
  vertex_at_.assign(cap_, -1);
  for (int k = 0; k < m; ++k) {
    slot_[variables[order[k]]] = k;
    vertex_at_[k] = variables[order[k]];
  }
}

// The augmented normal matrix [H g; g^T c] at the linearisation points,
// upper triangle, with the reserved blocks as identity and c one above
// chi2 so that the last pivot stays positive even where the residuals lie
// in J's range. Written straight into compressed columns from the block
// pattern (each edge adds to its two diagonal blocks, the block between
// them and its rows of g): a list of every scalar product, sorted and
// summed, cost as much as the factorisation itself.
bool PartialUpdater::AssembleAndFactorize() {
  NormalPattern pattern = PlanNormalPattern();
  std::vector<double> x(pattern.rows.size(), 0.0);
  const auto& edges = graph_->edges();
  for (size_t e = 0; e < edges.size(); ++e) AddEdgeTerms(e, pattern, &x);
  const int d = d_;
  for (int b = used_; b < cap_; ++b)
    for (int t = 0; t < d; ++t) x[pattern.col_ptr[b * d + t + 1] - 1] = 1.0;
  x.back() += 1.0;
  return factor_->Factorize(n_ + 1, pattern.col_ptr, pattern.rows, x);
}

// Block column c of H's upper triangle holds the blocks of the poses
// before c that share an edge with it (ascending), then its diagonal block;
// the gradient's column holds every placed unknown, then c.
PartialUpdater::NormalPattern PartialUpdater::PlanNormalPattern() const {
  const auto& edges = graph_->edges();
  std::vector<std::pair<int, int>> pairs;  // (column block, row block), row < column
  pairs.reserve(edges.size());
  for (const Edge& edge : edges) {
    if (edge.IsPrior()) continue;
    const int a = slot_[graph_->VertexIndex(edge.from)], b = slot_[graph_->VertexIndex(edge.to)];
    if (a >= 0 && b >= 0 && a != b) pairs.emplace_back(std::max(a, b), std::min(a, b));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  NormalPattern pattern;
  pattern.block_start.assign(cap_ + 1, 0);
  for (const auto& [c, r] : pairs) ++pattern.block_start[c + 1];
  for (int c = 0; c < cap_; ++c) pattern.block_start[c + 1] += pattern.block_start[c];
  pattern.block_rows.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) pattern.block_rows[k] = pairs[k].second;
  const int d = d_, placed = used_ * d_;
  pattern.col_ptr.assign(n_ + 2, 0);
  for (int c = 0; c < cap_; ++c) {
    const int above = d * (pattern.block_start[c + 1] - pattern.block_start[c]);
    for (int t = 0; t < d; ++t) pattern.col_ptr[c * d + t + 1] = above + t + 1;
  }
  pattern.col_ptr[n_ + 1] = placed + 1;
  for (int j = 0; j <= n_; ++j) pattern.col_ptr[j + 1] += pattern.col_ptr[j];
  pattern.rows.resize(pattern.col_ptr[n_ + 1]);
  for (int c = 0; c < cap_; ++c)
    for (int t = 0; t < d; ++t) {
      int* out = &pattern.rows[pattern.col_ptr[c * d + t]];
      for (int k = pattern.block_start[c]; k < pattern.block_start[c + 1]; ++k)
        for (int u = 0; u < d; ++u) *out++ = pattern.block_rows[k] * d + u;
      for (int u = 0; u <= t; ++u) *out++ = c * d + u;
    }
  for (int i = 0; i <= placed; ++i) pattern.rows[pattern.col_ptr[n_] + i] = i < placed ? i : rhs_;
  return pattern;
}

// Edge e's J^T J and J^T r (its whitened Jacobian and residual at the
// linearisation points), with r^T r in the gradient's diagonal entry.
void PartialUpdater::AddEdgeTerms(size_t e, const NormalPattern& pattern,
                                  std::vector<double>* values) const {
  const Edge& edge = graph_->edges()[e];
  const int d = d_;
  int block[2] = {slot_[graph_->VertexIndex(edge.from)], -1};
  if (!edge.IsPrior()) block[1] = slot_[graph_->VertexIndex(edge.to)];
  const double* j = &jr_[e * stride_];  // d x 2d, row-major
  const double* r = j + 2 * d * d;
  // Row t of J, column c of the block at end k.
  auto jac = [&](int t, int k, int c) { return j[t * 2 * d + k * d + c]; };
  double* x = values->data();
  const int* cp = pattern.col_ptr.data();
  const int g = cp[n_];  // the gradient's column
  for (int k = 0; k < 2; ++k) {
    const int b = block[k];
    if (b < 0) continue;
    const int above = pattern.block_start[b + 1] - pattern.block_start[b];
    for (int col = 0; col < d; ++col) {
      double* column = &x[cp[b * d + col] + above * d];
      for (int row = 0; row <= col; ++row)
        for (int t = 0; t < d; ++t) column[row] += jac(t, k, row) * jac(t, k, col);
      for (int t = 0; t < d; ++t) x[g + b * d + col] += jac(t, k, col) * r[t];
    }
  }
  for (int t = 0; t < d; ++t) x[cp[n_ + 1] - 1] += r[t] * r[t];
  if (block[0] < 0 || block[1] < 0 || block[0] == block[1]) return;
  // The block between the two ends, in the later one's column.
  const int lo = block[0] < block[1] ? 0 : 1, hi = 1 - lo;
  const int* first = &pattern.block_rows[pattern.block_start[block[hi]]];
  const int* last = &pattern.block_rows[pattern.block_start[block[hi] + 1]];
  const int q = static_cast<int>(std::lower_bound(first, last, block[lo]) - first);
  for (int col = 0; col < d; ++col) {
    double* column = &x[cp[block[hi] * d + col] + q * d];
    for (int row = 0; row < d; ++row)
      for (int t = 0; t < d; ++t) column[row] += jac(t, lo, row) * jac(t, hi, col);
  }
}

void PartialUpdater::ResetTree() {
  parent_.assign(n_ + 1, -1);
  children_.assign(n_ + 1, {});
  for (int j = 0; j < n_; ++j) {
    parent_[j] = factor_->Parent(j);
    if (parent_[j] >= 0) children_[parent_[j]].push_back(j);
  }
  stamp_.assign(n_ + 1, 0);
  done_.assign(n_ + 1, 0);
  block_stamp_.assign(cap_, 0);
  round_ = 0;
}

bool PartialUpdater::Rebuild(UpdateResult* out) {
  valid_ = false;
  out->refactorized = true;
  out->reason = reason_;
  reason_ = RebuildReason::kRefused;  // unless Update says otherwise before the next
  if (!Covers(*graph_)) return false;
  const GraphGauge gauge = ComputeGauge(*graph_);
  const auto& vertices = graph_->vertices();
  const size_t nv = vertices.size(), ne = graph_->edges().size();
  // The linearisation points: the estimate as it stands.
  x0_.resize(nv * p_);
  for (size_t v = 0; v < nv; ++v) {
    NormalizeRotation(graph_->vertices()[v]);
    std::copy_n(vertices[v].x.data(), p_, &x0_[v * p_]);
  }
  edges_of_.assign(nv, {});
  for (size_t e = 0; e < ne; ++e) AddEdgeToState(e);
  ComputeComponents();
  PlaceVariables(gauge.held);
  delta_.assign(n_, 0.0);
  for (size_t e = 0; e < ne; ++e) Linearize(e);
  if (!AssembleAndFactorize()) return false;
  edges_in_ = ne;
  edge_stamp_.assign(ne, 0);
  ResetTree();
  relinearize_.clear();
  waiting_.assign(nv, 0);
  ++round_;
  marked_.clear();
  for (int j = 0; j < used_ * d_; ++j) marked_.push_back(j);
  BackSubstitute(out);
  if (!WriteEstimates()) return false;
  nnz_at_build_ = factor_->NonZeros();
  out->factor_nonzeros = nnz_at_build_;
  updates_since_build_ = 0;
  valid_ = true;
  rebuild_ = false;
  return true;
}

// Entries of L on the path from column j to the root: what one column of
// an update or downdate starting there costs.
long PartialUpdater::PathEntries(int j) const {
  long entries = 0;
  for (; j >= 0 && j != rhs_; j = parent_[j]) entries += factor_->BelowCount(j) + 1;
  return entries;
}

// The poses waiting for re-linearisation, the farthest moved first, each
// whose downdates and updates fit in what is left of the budget: a loop
// closure that moves hundreds of poses spreads their re-linearisation over
// the next steps instead of costing one step a whole refactorisation. A
// pose deep in the elimination tree, whose path alone is over the budget,
// waits for the next fresh factorisation (or for a refused step, which
// re-linearises what it moved), off the queue: taking it anyway, one a
// step, made every step cost a path that grows with the graph (6 ms a step
// at 50,000 poses against 1 ms at 10,000, docs/benchmarks.md), and
// weighing it again at every step, a queue that grows with it.
std::vector<int> PartialUpdater::ChooseRelinearization() {
  std::vector<std::pair<double, int>> waiting;
  for (int v : relinearize_) {
    waiting_[v] = 0;
    const double* step = &delta_[slot_[v] * d_];
    double largest = 0;
    for (int c = 0; c < d_; ++c) largest = std::max(largest, std::abs(step[c]));
    if (largest > relinearize_threshold_) waiting.emplace_back(-largest, v);
  }
  const size_t weighed = std::min(waiting.size(), static_cast<size_t>(kRelinearizeCandidates));
  std::partial_sort(waiting.begin(), waiting.begin() + weighed, waiting.end());
  std::vector<int> chosen;
  relinearize_.clear();
  long spent = 0;
  for (size_t k = 0; k < waiting.size(); ++k) {
    const int v = waiting[k].second;
    waiting_[v] = 1;
    if (k >= weighed || spent >= relinearize_budget_) {
      relinearize_.push_back(v);
      continue;
    }
    const long cost =
        2L * d_ * static_cast<long>(edges_of_[v].size()) * PathEntries(slot_[v] * d_);
    if (spent + cost <= relinearize_budget_) {
      spent += cost;
      chosen.push_back(v);
      waiting_[v] = 0;
    } else if (cost <= relinearize_budget_) {
      relinearize_.push_back(v);  // next time
    }  // else parked (still marked waiting) until the next fresh factorisation
  }
  return chosen;
}

void PartialUpdater::CollectRelinearization(Columns* up, Columns* down, UpdateResult* out) {
  const std::vector<int> chosen = ChooseRelinearization();
  Relinearize(chosen, up, down);
  out->relinearized_vertices = static_cast<int>(chosen.size());
}

// The edges of the chosen poses re-linearised at the poses' estimates: the
// terms they added at the old points downdated, the new ones updated.
void PartialUpdater::Relinearize(const std::vector<int>& chosen, Columns* up, Columns* down) {
  std::vector<int> edges;
  edge_stamp_.resize(graph_->edges().size(), 0);
  for (int v : chosen)
    for (int e : edges_of_[v])
      if (edge_stamp_[e] != round_) {
        edge_stamp_[e] = round_;
        edges.push_back(e);
        AppendColumns(e, down);  // the term it added, at the old points
      }
  auto& vertices = graph_->vertices();
  for (int v : chosen) {
    std::copy_n(vertices[v].x.data(), p_, &x0_[v * p_]);
    std::fill_n(&delta_[slot_[v] * d_], d_, 0.0);
  }
  for (int e : edges) {
    Linearize(e);
    AppendColumns(e, up);
  }
}

// New poses take the next reserved blocks: their identity comes out (a
// downdate) once their edges are in.
void PartialUpdater::TakeInNewEdges(Columns* up, Columns* down, UpdateResult* out) {
  const auto& edges = graph_->edges();
  auto& vertices = graph_->vertices();
  for (size_t e = edges_in_; e < edges.size(); ++e) {
    for (int64_t id : {edges[e].from, edges[e].to}) {
      if (id == edges[e].to && edges[e].IsPrior()) break;
      const size_t v = graph_->VertexIndex(id);
      if (slot_[v] != -1) continue;
      slot_[v] = used_;
      vertex_at_[used_] = static_cast<int>(v);
      NormalizeRotation(vertices[v]);
      std::copy_n(vertices[v].x.data(), p_, &x0_[v * p_]);
      for (int c = 0; c < d_; ++c) {
        delta_[used_ * d_ + c] = 0;
        down->Push(used_ * d_ + c, 1.0);
        down->Close();
      }
      ++used_;
    }
    AddEdgeToState(e);
    Linearize(e);
    AppendColumns(e, up);
    ++out->new_edges;
  }
}

void PartialUpdater::Reparent(int j, int p) {
  const int old = parent_[j];
  if (old >= 0) {
    auto& siblings = children_[old];
    auto it = std::find(siblings.begin(), siblings.end(), j);
    if (it != siblings.end()) {
      *it = siblings.back();
      siblings.pop_back();
    }
  }
  parent_[j] = p;
  if (p >= 0) children_[p].push_back(j);
}

// The columns a modification changed are those on the paths from each of
// its columns' first rows to the root, in the tree after it.
void PartialUpdater::MarkPath(int j) {
  while (j >= 0 && j != rhs_ && stamp_[j] != round_) {
    stamp_[j] = round_;
    marked_.push_back(j);
    const int p = factor_->Parent(j);
    if (p != parent_[j]) Reparent(j, p);
    j = p;
  }
}

// L^T dx = -l (l: the factor's last row, L^-1 g scaled by D^-1), from the
// root down: the marked columns, and below them the subtrees under a step
// that changed by more than the wildfire threshold.
void PartialUpdater::BackSubstitute(UpdateResult* out) {
  std::priority_queue<int> heap(std::less<int>(), marked_);
  changed_blocks_.clear();
  int solved = 0;
  while (!heap.empty()) {
    const int j = heap.top();
    heap.pop();
    if (done_[j] == round_) continue;
    done_[j] = round_;
    const int count = factor_->BelowCount(j);
    const int* rows = factor_->BelowRows(j);
    const double* values = factor_->BelowValues(j);
    double v = 0;
    for (int t = 0; t < count; ++t) v += rows[t] == rhs_ ? values[t] : values[t] * delta_[rows[t]];
    v = -v;
    const double change = std::abs(v - delta_[j]);
    delta_[j] = v;
    ++solved;
    if (change > 0 && block_stamp_[j / d_] != round_) {
      block_stamp_[j / d_] = round_;
      changed_blocks_.push_back(j / d_);
    }
    if (change > wildfire_threshold_)
      for (int c : children_[j])
        if (done_[c] != round_) heap.push(c);
  }
  out->solved_unknowns += solved;
}

double PartialUpdater::ChangedCost() {
  const auto& edges = graph_->edges();
  cost_stamp_.resize(edges.size(), 0);
  ++cost_round_;
  double sum = 0;
  for (int b : changed_blocks_) {
    const int v = vertex_at_[b];
    if (v < 0) continue;
    for (int e : edges_of_[v]) {
      if (cost_stamp_[e] == cost_round_) continue;
      cost_stamp_[e] = cost_round_;
      sum += EdgeChi2(*graph_, edges[e]);
    }
  }
  return sum;
}

// The new estimate is kept only when it does not raise the cost of the
// edges it moves (the rest of the graph's cost is unchanged): far from the
// kept linearisation, on long loops, the linear step can diverge, and the
// caller then solves the graph whole from the estimate before it.
bool PartialUpdater::WriteEstimates() {
  auto& vertices = graph_->vertices();
  const double before = ChangedCost();
  saved_.clear();
  for (int b : changed_blocks_) {
    const int v = vertex_at_[b];
    if (v < 0) continue;
    saved_.push_back(vertices[v].x);
    manifold_->Plus(LinPoint(v), &delta_[b * d_], vertices[v].x.data());
  }
  const double after = ChangedCost();
  if (!(after <= kAcceptedCostGrowth * before + 1e-12)) {
    size_t k = 0;
    for (int b : changed_blocks_)
      if (vertex_at_[b] >= 0) vertices[vertex_at_[b]].x = saved_[k++];
    valid_ = false;
    return false;
  }
  for (int b : changed_blocks_) {
    const int v = vertex_at_[b];
    if (v < 0) continue;
    const double* step = &delta_[b * d_];
    double largest = 0;
    for (int c = 0; c < d_; ++c) largest = std::max(largest, std::abs(step[c]));
    if (largest > relinearize_threshold_ && !waiting_[v]) {
      waiting_[v] = 1;
      relinearize_.push_back(v);
    }
  }
  return true;
}

bool PartialUpdater::Update(UpdateResult* out) {
  const auto start = std::chrono::steady_clock::now();
  *out = UpdateResult{};
  const auto& edges = graph_->edges();
  bool ok = true;
  if (edges.empty()) {
    out->time_s = Seconds(start);
    return true;
  }
  if (valid_ && !rebuild_) {
    const size_t nv = graph_->vertices().size();
    slot_.resize(nv, -1);
    x0_.resize(nv * p_);
    edges_of_.resize(nv);
    waiting_.resize(nv, 0);
    // New poses need room; the gauge must stay where it is.
    int fresh = 0;
    for (size_t e = edges_in_; e < edges.size() && !rebuild_; ++e) {
      if (!TakeInGauge(edges[e])) {
        rebuild_ = true;
        reason_ = RebuildReason::kGauge;
        break;
      }
      for (int64_t id : {edges[e].from, edges[e].to})
        fresh += slot_[graph_->VertexIndex(id)] == -1;
    }
    if (!rebuild_ && used_ + fresh > cap_) {
      rebuild_ = true;
      reason_ = RebuildReason::kRoom;
    }
  }
  if (!valid_ || rebuild_) {
    ok = Rebuild(out);
  } else {
    ok = Modify(out);
  }
  if (ok && ++updates_since_build_ % 16 == 0) {
    out->factor_nonzeros = factor_->NonZeros();
    const double bound = std::max(static_cast<double>(fill_bound_),
                                  fill_fraction_ * static_cast<double>(nnz_at_build_));
    if (static_cast<double>(out->factor_nonzeros - nnz_at_build_) > bound) {
      rebuild_ = true;
      reason_ = RebuildReason::kFill;
    }
  }
  out->time_s = Seconds(start);
  return ok;
}

bool PartialUpdater::Modify(UpdateResult* out) {
  ++round_;
  Columns up, down;
  CollectRelinearization(&up, &down, out);
  TakeInNewEdges(&up, &down, out);
  edges_in_ = graph_->edges().size();
  if (!ModifyAndSolve(up, down, out)) return false;
  if (WriteEstimates()) return true;
  // Refused: the kept linearisation is too far from where the step went
  // (a long loop closed). The poses it moved are re-linearised where they
  // stand and the step taken again, unless that costs more than ordering
  // and factorising afresh, which the caller then does.
  std::vector<int> moved;
  long cost = 0;
  for (int b : changed_blocks_) {
    const int v = vertex_at_[b];
    if (v < 0) continue;
    moved.push_back(v);
    cost += 2L * d_ * static_cast<long>(edges_of_[v].size()) * PathEntries(b * d_);
    if (cost > kRetryCostPerFactorEntry * factor_->NonZeros()) return false;
  }
  ++round_;
  Columns up_again, down_again;
  Relinearize(moved, &up_again, &down_again);
  out->relinearized_vertices += static_cast<int>(moved.size());
  ++out->retried;
  valid_ = true;
  return ModifyAndSolve(up_again, down_again, out) && WriteEstimates();
}

// Applies the columns to the factor (updates first: every partial downdate
// then leaves the matrix above the final one, positive definite whenever
// that is) and solves again where they reach.
bool PartialUpdater::ModifyAndSolve(const Columns& up, const Columns& down, UpdateResult* out) {
  if (!factor_->Modify(true, up.k, up.p, up.i, up.x) ||
      !factor_->Modify(false, down.k, down.p, down.i, down.x)) {
    valid_ = false;
    return false;
  }
  marked_.clear();
  for (int c = 0; c < up.k; ++c) MarkPath(up.First(c));
  for (int c = 0; c < down.k; ++c) MarkPath(down.First(c));
  for (int j : marked_)
    if (!(factor_->Pivot(j) > 0) || !std::isfinite(factor_->Pivot(j))) {
      valid_ = false;  // a pose its edges leave undetermined: solved whole, the solver says why
      return false;
    }
  BackSubstitute(out);
  return true;
}

}  // namespace cairn
