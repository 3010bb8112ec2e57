#include "cairn/graph/pose_graph.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstring>
#include <limits>
#include <numeric>
#include <queue>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace cairn {

const char* ToString(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry: return "odometry";
    case EdgeKind::kLoopClosure: return "loop closure";
    case EdgeKind::kPrior: return "prior";
    case EdgeKind::kLandmark: return "landmark observation";
    case EdgeKind::kLandmarkPrior: return "landmark prior";
  }
  return "?";
}

size_t VertexIndex::Find(int64_t id) const {
  if (!dense_) {
    const auto it = sparse_.find(id);
    return it == sparse_.end() ? kAbsent : it->second;
  }
  // Unsigned: the distance of two int64 ids may not fit in an int64.
  const uint64_t k = static_cast<uint64_t>(id) - static_cast<uint64_t>(base_);
  if (id < base_ || k >= slots_.size() || slots_[k] == 0) return kAbsent;
  return slots_[k] - 1;
}

size_t VertexIndex::At(int64_t id) const {
  const size_t position = Find(id);
  if (position == kAbsent) throw std::out_of_range("no vertex " + std::to_string(id));
  return position;
}

void VertexIndex::Insert(int64_t id, size_t position) {
  if (dense_ && InsertDense(id, position)) return;
  if (dense_) ToSparse();
  sparse_.emplace(id, position);
}

// False (nothing changed) when the ids would no longer be dense: their range
// more than twice their number (and some slack), or a position beyond 32 bits.
bool VertexIndex::InsertDense(int64_t id, size_t position) {
  if (position >= std::numeric_limits<uint32_t>::max()) return false;
  const int64_t low = count_ ? std::min(low_, id) : id, high = count_ ? std::max(high_, id) : id;
  const uint64_t range = static_cast<uint64_t>(high) - static_cast<uint64_t>(low);
  if (range > 2 * static_cast<uint64_t>(count_ + 1) + 1024) return false;
  if (count_ == 0) base_ = id;
  if (id < base_) {
    // Room in front for as many again, so that ids arriving in descending
    // order cost amortised constant time (the range bound holds for the ids
    // held, the slots may be up to twice that).
    const uint64_t grow = std::max<uint64_t>(static_cast<uint64_t>(base_) - static_cast<uint64_t>(id),
                                             slots_.size());
    const uint64_t lowest = static_cast<uint64_t>(std::numeric_limits<int64_t>::min());
    const uint64_t room = std::min<uint64_t>(grow, static_cast<uint64_t>(base_) - lowest);
    slots_.insert(slots_.begin(), room, 0);
    base_ = static_cast<int64_t>(static_cast<uint64_t>(base_) - room);
  }
  const uint64_t k = static_cast<uint64_t>(id) - static_cast<uint64_t>(base_);
  if (k >= slots_.size()) slots_.resize(k + 1, 0);
  slots_[k] = static_cast<uint32_t>(position + 1);
  low_ = low;
  high_ = high;
  ++count_;
  return true;
}

void VertexIndex::ToSparse() {
  sparse_.reserve(count_ + 1);
  for (size_t k = 0; k < slots_.size(); ++k)
    if (slots_[k] != 0)
      sparse_.emplace(static_cast<int64_t>(static_cast<uint64_t>(base_) + k), slots_[k] - 1);
  std::vector<uint32_t>().swap(slots_);
  dense_ = false;
}

EdgeList::EdgeList(int dimension)
    : dimension_(dimension), stride_(dimension == 3 ? 7 : 3), info_stride_(dimension == 3 ? 21 : 6) {}

int EdgeList::MeasurementSize(EdgeKind kind) const {
  return IsLandmarkKind(kind) ? dimension_ : (dimension_ == 3 ? 7 : 3);
}

int EdgeList::InformationSize(EdgeKind kind) const {
  return IsLandmarkKind(kind) ? dimension_ : (dimension_ == 3 ? 6 : 3);
}

void EdgeList::Encode(const Edge& e, double* v) const {
  std::fill(v, v + stride_, 0.0);
  const int m = MeasurementSize(e.kind);
  for (int i = 0; i < m; ++i) v[i] = e.z[i];
}

// The index of e's triangle: one of the recent ones if equal to the bit
// (so -0.0 and NaN payloads come back as read), else a new entry.
uint32_t EdgeList::Intern(const Edge& e) {
  double t[21] = {};
  const int n = InformationSize(e.kind);
  double* v = t;
  for (int r = 0; r < n; ++r)
    for (int c = r; c < n; ++c) *v++ = e.information(r, c);
  const size_t bytes = info_stride_ * sizeof(double);
  for (int i = 0; i < recent_count_; ++i)
    if (std::memcmp(infos_.data() + recent_[i] * info_stride_, t, bytes) == 0) return recent_[i];
  const size_t index = infos_.size() / info_stride_;
  if (index > std::numeric_limits<uint32_t>::max()) throw std::length_error("too many edges");
  infos_.insert(infos_.end(), t, t + info_stride_);
  recent_[recent_next_] = static_cast<uint32_t>(index);
  recent_next_ = (recent_next_ + 1) % kRecent;
  recent_count_ = std::min(recent_count_ + 1, kRecent);
  return static_cast<uint32_t>(index);
}

Edge EdgeList::operator[](size_t k) const {
  const Head& h = heads_[k];
  Edge e;
  e.kind = h.kind;
  e.offset = h.offset;
  e.from = h.from;
  e.to = h.to;
  const double* v = values_.data() + k * stride_;
  const int m = MeasurementSize(h.kind), n = InformationSize(h.kind);
  for (int i = 0; i < m; ++i) e.z[i] = v[i];
  const double* t = infos_.data() + static_cast<size_t>(info_[k]) * info_stride_;
  e.information.v_.fill(0.0);
  for (int r = 0; r < n; ++r)
    for (int c = r; c < n; ++c) e.information.v_[SymmetricMatrix6::Index(r, c)] = *t++;
  return e;
}

Edge EdgeList::at(size_t k) const {
  if (k >= size()) throw std::out_of_range("no edge " + std::to_string(k));
  return (*this)[k];
}

// Room for n distinct triangles too: mapped, it takes memory only as far as
// they are written.
void EdgeList::Reserve(size_t n) {
  heads_.reserve(n);
  values_.reserve(n * stride_);
  info_.reserve(n);
  infos_.reserve(n * info_stride_);
}

void EdgeList::Push(const Edge& e) {
  heads_.push_back(Head{e.from, e.to, e.offset, e.kind});
  values_.resize(values_.size() + stride_);
  Encode(e, values_.data() + values_.size() - stride_);
  info_.push_back(Intern(e));
}

void EdgeList::Set(size_t k, const Edge& e) {
  heads_.at(k) = Head{e.from, e.to, e.offset, e.kind};
  Encode(e, values_.data() + k * stride_);
  info_[k] = Intern(e);
}

// Triangles no edge uses any more stay in the table.
void EdgeList::Keep(const std::vector<bool>& keep) {
  size_t kept = 0;
  for (size_t k = 0; k < heads_.size(); ++k) {
    if (!keep.at(k)) continue;
    heads_[kept] = heads_[k];
    std::copy_n(values_.begin() + k * stride_, stride_, values_.begin() + kept * stride_);
    info_[kept] = info_[k];
    ++kept;
  }
  heads_.resize(kept);
  values_.resize(kept * stride_);
  info_.resize(kept);
}

PoseGraph::PoseGraph(int dimension) : dimension_(dimension), edges_(dimension) {
  if (dimension != 2 && dimension != 3) throw std::invalid_argument("dimension must be 2 or 3");
}

Vertex& PoseGraph::AddVertex(int64_t id, const PoseParams& x, bool fixed) {
  if (HasVertex(id)) throw std::invalid_argument("duplicate vertex id " + std::to_string(id));
  index_.Insert(id, vertices_.size());
  vertices_.push_back(Vertex{id, x, fixed});
  return vertices_.back();
}

Vertex& PoseGraph::AddLandmark(int64_t id, const Eigen::Vector3d& p, bool fixed) {
  PoseParams x{};
  for (int i = 0; i < dimension_; ++i) x[i] = p[i];
  Vertex& v = AddVertex(id, x, fixed);
  v.landmark = true;
  ++landmarks_;
  return v;
}

void PoseGraph::SetOffset(int32_t id, const SE3& offset) { offsets_[id] = offset; }

Vertex& PoseGraph::AddVertex(int64_t id, const SE2& pose, bool fixed) {
  if (dimension_ != 2) throw std::invalid_argument("an SE2 vertex in a 3D graph");
  return AddVertex(id, ToParams(pose), fixed);
}

Vertex& PoseGraph::AddVertex(int64_t id, const SE3& pose, bool fixed) {
  if (dimension_ != 3) throw std::invalid_argument("an SE3 vertex in a 2D graph");
  return AddVertex(id, ToParams(pose), fixed);
}

namespace {

// Whether vertex `id` is a landmark (true) or a pose, as the edge needs it.
void CheckSort(const PoseGraph& graph, int64_t id, bool landmark, const Edge& edge) {
  if (graph.vertex(id).landmark == landmark) return;
  throw std::invalid_argument(std::string(ToString(edge.kind)) + " edge on vertex " +
                              std::to_string(id) + ", which is " +
                              (landmark ? "a pose, not a landmark" : "a landmark, not a pose"));
}

}  // namespace

void PoseGraph::AddEdge(const Edge& edge) {
  if (!HasVertex(edge.from))
    throw std::invalid_argument("edge to vertex " + std::to_string(edge.from) +
                                ", which does not exist");
  if (!edge.IsPrior()) {
    if (!HasVertex(edge.to))
      throw std::invalid_argument("edge to vertex " + std::to_string(edge.to) +
                                  ", which does not exist");
    if (edge.from == edge.to)
      throw std::invalid_argument("edge joins vertex " + std::to_string(edge.from) +
                                  " to itself");
  }
  CheckSort(*this, edge.from, edge.kind == EdgeKind::kLandmarkPrior, edge);
  if (!edge.IsPrior()) CheckSort(*this, edge.to, edge.kind == EdgeKind::kLandmark, edge);
  if (edge.kind == EdgeKind::kLandmark && dimension_ == 3 && !HasOffset(edge.offset))
    throw std::invalid_argument("landmark observation through offset " +
                                std::to_string(edge.offset) + ", which is not defined");
  // ClassifyInformation's tolerance; the matrix it sees is symmetric now.
  if (!(edge.information.asymmetry() <= 1e-9))
    throw std::invalid_argument("information matrix is zero, not finite or not symmetric");
  switch (ClassifyInformation(Information(edge))) {
    case InformationClass::kPositiveDefinite:
    case InformationClass::kSingular: break;
    case InformationClass::kIndefinite:
      throw std::invalid_argument("information matrix is not positive semi-definite");
    case InformationClass::kUnusable:
      throw std::invalid_argument("information matrix is zero, not finite or not symmetric");
  }
  // The unused parts are not stored: they read back as zero.
  Edge e = edge;
  if (e.kind != EdgeKind::kLandmark || dimension_ == 2) e.offset = 0;
  edges_.Push(e);
}

void PoseGraph::SetEdge(size_t k, const Edge& edge) {
  Edge e = edge;
  if (e.kind != EdgeKind::kLandmark || dimension_ == 2) e.offset = 0;
  edges_.Set(k, e);
}

void PoseGraph::KeepEdges(const std::vector<bool>& keep) {
  if (keep.size() != edges_.size()) throw std::invalid_argument("KeepEdges: one flag per edge");
  edges_.Keep(keep);
}

size_t PoseGraph::CountEdges(EdgeKind kind) const {
  size_t n = 0;
  for (size_t k = 0; k < edges_.size(); ++k) n += edges_.kind(k) == kind;
  return n;
}

size_t PoseGraph::CountFixed() const {
  size_t n = 0;
  for (const Vertex& v : vertices_) n += v.fixed;
  return n;
}

SymmetricMatrix6& SymmetricMatrix6::operator=(const Matrix6d& m) {
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) v_[Index(r, c)] = m(r, c);
  // Not finite anywhere (the lower triangle too): refused as asymmetric.
  const double off = (m - m.transpose()).cwiseAbs().maxCoeff();
  asymmetry_ = !m.allFinite() ? std::numeric_limits<double>::infinity()
               : off == 0     ? 0.0
                              : off / m.cwiseAbs().maxCoeff();
  return *this;
}

const Matrix6d SymmetricMatrix6::Full() const {
  Matrix6d m;
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) m(r, c) = m(c, r) = v_[Index(r, c)];
  return m;
}

void SymmetricMatrix6::SetTopLeft(const Eigen::MatrixXd& m) {
  Matrix6d full = Matrix6d::Zero();
  full.topLeftCorner(m.rows(), m.cols()) = m;
  *this = full;
}

void SymmetricMatrix6::setZero() {
  v_.fill(0.0);
  asymmetry_ = 0;
}

SymmetricMatrix6& SymmetricMatrix6::operator*=(double s) {
  for (double& x : v_) x *= s;
  return *this;
}

double SymmetricMatrix6::trace() const {
  double t = 0;
  for (int k = 0; k < 6; ++k) t += v_[Index(k, k)];
  return t;
}

const Vector6d SymmetricMatrix6::diagonal() const {
  Vector6d d;
  for (int k = 0; k < 6; ++k) d[k] = v_[Index(k, k)];
  return d;
}

Eigen::MatrixXd PoseGraph::Information(const Edge& e) const {
  const int n = ResidualSize(e);
  return e.information.topLeftCorner(n, n);
}

void RequireNoLandmarks(const PoseGraph& graph, const std::string& what) {
  if (graph.HasLandmarks())
    throw std::invalid_argument(what + " does not handle landmarks, and this graph has " +
                                std::to_string(graph.CountLandmarks()));
}

SE2 ToSE2(const PoseParams& p) { return SE2(p[0], p[1], p[2]); }

SE3 ToSE3(const PoseParams& p) { return SE3::FromVector(Eigen::Map<const Vector7d>(p.data())); }

PoseParams ToParams(const SE2& pose) { return {pose.x(), pose.y(), pose.theta(), 0, 0, 0, 0}; }

PoseParams ToParams(const SE3& pose) {
  PoseParams p;
  Eigen::Map<Vector7d>(p.data()) = pose.ToVector();
  return p;
}

EdgeKind KindForBetween(int64_t from, int64_t to) {
  return (to == from + 1 || from == to + 1) ? EdgeKind::kOdometry : EdgeKind::kLoopClosure;
}

bool IsSymmetricPositiveDefinite(const Eigen::MatrixXd& info) {
  if (!info.allFinite()) return false;
  const double scale = info.cwiseAbs().maxCoeff();
  if (!(scale > 0)) return false;
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  Eigen::LLT<Eigen::MatrixXd> llt(info);
  if (llt.info() != Eigen::Success) return false;
  // A factor with a zero pivot passes LLT in floating point; demand a real one.
  return llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0;
}

InformationClass ClassifyInformation(const Eigen::MatrixXd& info, double* smallest) {
  if (!info.allFinite()) return InformationClass::kUnusable;
  const double scale = info.cwiseAbs().maxCoeff();
  if (!(scale > 0)) return InformationClass::kUnusable;
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return InformationClass::kUnusable;
  if (IsSymmetricPositiveDefinite(info)) return InformationClass::kPositiveDefinite;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(info, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
  const double largest = lambda.cwiseAbs().maxCoeff();
  const double ratio = lambda[0] / largest;
  if (smallest) *smallest = ratio;
  return ratio < -kSemiDefiniteTolerance ? InformationClass::kIndefinite
                                         : InformationClass::kSingular;
}

double ClipToSemiDefinite(Eigen::MatrixXd* info) {
  const Eigen::MatrixXd sym = 0.5 * (*info + info->transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sym);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double largest = lambda.cwiseAbs().maxCoeff();
  if (!(largest > 0) || lambda[0] >= 0) return 0;
  const Eigen::MatrixXd& v = eig.eigenvectors();
  *info = v * lambda.cwiseMax(0.0).asDiagonal() * v.transpose();
  *info = 0.5 * (*info + info->transpose());  // exactly symmetric, as files write it
  return -lambda[0] / largest;
}

namespace {

// Adjacency by vertex index: (edge index, neighbour index) pairs.
std::vector<std::vector<std::pair<size_t, size_t>>> Adjacency(const PoseGraph& graph) {
  std::vector<std::vector<std::pair<size_t, size_t>>> adj(graph.vertices().size());
  const auto& edges = graph.edges();
  for (size_t k = 0; k < edges.size(); ++k) {
    if (!edges[k].JoinsPoses()) continue;
    const size_t a = graph.VertexIndex(edges[k].from), b = graph.VertexIndex(edges[k].to);
    adj[a].emplace_back(k, b);
    adj[b].emplace_back(k, a);
  }
  return adj;
}

}  // namespace

Eigen::Vector3d ObservedPoint(const PoseGraph& graph, const Edge& e, const PoseParams& pose) {
  if (graph.dimension() == 2) {
    const Eigen::Vector2d p = ToSE2(pose) * Eigen::Vector2d(e.z[0], e.z[1]);
    return {p.x(), p.y(), 0.0};
  }
  const SE3 sensor = ToSE3(pose) * graph.offset(e.offset);
  return sensor * Eigen::Vector3d(e.z[0], e.z[1], e.z[2]);
}

void PlaceLandmarks(PoseGraph& graph) {
  if (!graph.HasLandmarks()) return;
  std::vector<bool> placed(graph.vertices().size(), false);
  for (const Edge& e : graph.edges()) {
    if (e.kind != EdgeKind::kLandmark) continue;
    const size_t l = graph.VertexIndex(e.to);
    if (placed[l]) continue;
    placed[l] = true;
    Vertex& v = graph.vertices()[l];
    if (v.fixed) continue;
    const Eigen::Vector3d p = ObservedPoint(graph, e, graph.vertex(e.from).x);
    for (int i = 0; i < graph.dimension(); ++i) v.x[i] = p[i];
  }
}

PoseParams ChainMeasurement(const PoseGraph& graph, const Edge& e, const PoseParams& from_pose,
                            bool forward) {
  if (graph.dimension() == 2) {
    const SE2 z = ToSE2(e.z);
    return ToParams(ToSE2(from_pose) * (forward ? z : z.Inverse()));
  }
  const SE3 z = ToSE3(e.z);
  return ToParams(ToSE3(from_pose) * (forward ? z : z.Inverse()));
}

void ChainAlongSpanningTree(PoseGraph& graph) {
  auto& vertices = graph.vertices();
  const size_t n = vertices.size();
  const auto adj = Adjacency(graph);
  const int dim = graph.TangentSize();
  std::vector<double> certainty(graph.edges().size());
  for (size_t k = 0; k < graph.edges().size(); ++k)
    certainty[k] = graph.edges()[k].information.topLeftCorner(dim, dim).trace();

  // Roots first: fixed vertices, then the rest by id.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (vertices[a].fixed != vertices[b].fixed) return vertices[a].fixed;
    return vertices[a].id < vertices[b].id;
  });

  std::vector<bool> done(n, false);
  // Prim's algorithm on a max-heap of (certainty, edge, vertex reached).
  using Item = std::tuple<double, size_t, size_t>;
  for (size_t root : order) {
    if (done[root]) continue;
    done[root] = true;
    std::priority_queue<Item> heap;
    auto push_from = [&](size_t v) {
      for (const auto& [k, w] : adj[v])
        if (!done[w]) heap.emplace(certainty[k], k, w);
    };
    push_from(root);
    while (!heap.empty()) {
      const auto [c, k, w] = heap.top();
      heap.pop();
      if (done[w]) continue;
      const Edge& e = graph.edges()[k];
      const bool forward = graph.VertexIndex(e.to) == w;
      const size_t from = forward ? graph.VertexIndex(e.from) : graph.VertexIndex(e.to);
      if (!vertices[w].fixed) vertices[w].x = ChainMeasurement(graph, e, vertices[from].x, forward);
      done[w] = true;
      push_from(w);
    }
  }
  PlaceLandmarks(graph);
}

std::vector<std::vector<int64_t>> ConnectedComponents(const PoseGraph& graph,
                                                      bool through_landmarks) {
  const size_t n = graph.vertices().size();
  std::vector<size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const Edge& e : graph.edges()) {
    if (e.IsPrior() || (!through_landmarks && !e.JoinsPoses())) continue;
    const size_t a = find(graph.VertexIndex(e.from)), b = find(graph.VertexIndex(e.to));
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::unordered_map<size_t, size_t> slot;
  std::vector<std::vector<int64_t>> components;
  for (size_t i = 0; i < n; ++i) {
    const size_t r = find(i);
    auto it = slot.find(r);
    if (it == slot.end()) {
      it = slot.emplace(r, components.size()).first;
      components.emplace_back();
    }
    components[it->second].push_back(graph.vertices()[i].id);
  }
  for (auto& c : components) std::sort(c.begin(), c.end());
  std::sort(components.begin(), components.end(),
            [](const auto& a, const auto& b) { return a.front() < b.front(); });
  return components;
}

}  // namespace cairn
