// The pose graph: vertices (robot poses and point landmarks) and edges
// (odometry, loop closures, priors, landmark observations) with their
// measurements and information matrices, and what follows from the graph
// alone (its connected components, measurements chained along a spanning
// tree). One graph is either planar (SE2, XY points) or spatial (SE3, XYZ
// points), never both.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <deque>
#include <iterator>
#include <map>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cairn/graph/geometry.h"
#include "cairn/graph/mapped_allocator.h"

namespace cairn {

// kLandmark: a pose observes a point (from: the pose, to: the landmark);
// kLandmarkPrior: an absolute measurement of a point.
enum class EdgeKind { kOdometry, kLoopClosure, kPrior, kLandmark, kLandmarkPrior };
const char* ToString(EdgeKind kind);
// An edge on a point: an observation or a point prior.
inline bool IsLandmarkKind(EdgeKind kind) {
  return kind == EdgeKind::kLandmark || kind == EdgeKind::kLandmarkPrior;
}

// A pose's parameters, laid out as g2o writes them: (x, y, theta) in 2D,
// (x, y, z, qx, qy, qz, qw) in 3D; a landmark's point is the first 2 or 3.
// Solvers optimise these arrays in place.
using PoseParams = std::array<double, 7>;

struct Vertex {
  int64_t id = 0;
  PoseParams x{};
  bool fixed = false;
  bool landmark = false;  // a point (in the padding after `fixed`: no growth)
};

// A symmetric 6x6 matrix kept as its upper triangle (21 doubles, not 36):
// an edge's information, of which a graph holds one per edge (at a million
// edges, 190 MB saved). Assigned from a full matrix it keeps the upper
// triangle and remembers how far from symmetric that matrix was, so that
// PoseGraph::AddEdge can still refuse an asymmetric one.
class SymmetricMatrix6 {
 public:
  SymmetricMatrix6() {
    for (int i = 0; i < 6; ++i) v_[Index(i, i)] = 1.0;  // the identity
  }
  SymmetricMatrix6(const Matrix6d& m) { *this = m; }  // NOLINT: as the Matrix6d it replaced
  SymmetricMatrix6& operator=(const Matrix6d& m);

  const Matrix6d Full() const;
  operator Matrix6d() const { return Full(); }  // NOLINT
  double operator()(int r, int c) const { return v_[Index(r, c)]; }
  double& operator()(int r, int c) { return v_[Index(r, c)]; }
  // Blocks are copies, const so that writing to one does not compile (it
  // would be lost): writes go through SetTopLeft or operator().
  template <int R, int C>
  const Eigen::Matrix<double, R, C> topLeftCorner() const {
    return Full().topLeftCorner<R, C>();
  }
  const Eigen::MatrixXd topLeftCorner(int rows, int cols) const {
    return Full().topLeftCorner(rows, cols);
  }
  template <int R, int C>
  const Eigen::Matrix<double, R, C> bottomRightCorner() const {
    return Full().bottomRightCorner<R, C>();
  }
  // The top-left block set to the square matrix m, every other entry zero.
  void SetTopLeft(const Eigen::MatrixXd& m);
  void setZero();
  SymmetricMatrix6& operator*=(double s);
  double trace() const;
  const Vector6d diagonal() const;
  const Matrix6d inverse() const { return Full().inverse(); }
  bool isApprox(const SymmetricMatrix6& o, double precision = 1e-12) const {
    return Full().isApprox(o.Full(), precision);
  }
  // max |m - m^T| / max |m| of the last full matrix assigned (infinite if
  // it was not finite); setZero clears it, the other writes keep it.
  double asymmetry() const { return asymmetry_; }
  bool operator==(const SymmetricMatrix6& o) const { return v_ == o.v_; }

 private:
  friend class EdgeList;
  static int Index(int r, int c) {
    if (r > c) std::swap(r, c);
    return r * 6 - r * (r - 1) / 2 + (c - r);
  }
  std::array<double, 21> v_{};
  double asymmetry_ = 0;
};

struct Edge {
  EdgeKind kind = EdgeKind::kOdometry;
  // 3D landmark observations: the PARAMS_SE3OFFSET id of the sensor offset
  // (PoseGraph::offset). In the padding after `kind`: no growth.
  int32_t offset = 0;
  int64_t from = 0;  // the constrained vertex of a prior; the pose of an observation
  int64_t to = -1;   // unused by a prior; the landmark of an observation
  PoseParams z{};    // measurement, laid out like a vertex (a point's: its first 2 or 3)
  // The residual's block, top-left (3x3 or 6x6 for poses, 2x2 or 3x3 for
  // points); the rest zero once added.
  SymmetricMatrix6 information;

  // A unary edge (on `from` alone).
  bool IsPrior() const { return kind == EdgeKind::kPrior || kind == EdgeKind::kLandmarkPrior; }
  bool IsLandmark() const { return IsLandmarkKind(kind); }
  // Odometry or a loop closure: a relative pose between two poses.
  bool JoinsPoses() const { return kind == EdgeKind::kOdometry || kind == EdgeKind::kLoopClosure; }
};

// The graph's edges, each stored in what its dimension uses (a 2D edge's
// 3 measurement doubles, not an Edge's 256 bytes) and given out as an Edge,
// by value: `for (const Edge& e : graph.edges())` and `graph.edges()[k]`
// read as from a vector. Information matrices are interned: an edge holds
// the index of its triangle in a table, and an edge whose triangle is, bit
// for bit, one of the last few stored shares it. Files and front-ends mostly
// give every edge of a kind the same information (a 3D edge then takes 84
// bytes instead of 248); when all differ, each costs 4 bytes more.
class EdgeList {
 public:
  class const_iterator {
   public:
    using iterator_category = std::random_access_iterator_tag;
    using value_type = Edge;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = Edge;
    const_iterator() = default;
    Edge operator*() const { return (*list_)[k_]; }
    Edge operator[](difference_type n) const { return (*list_)[k_ + n]; }
    const_iterator& operator++() { return ++k_, *this; }
    const_iterator operator++(int) { return const_iterator(list_, k_++); }
    const_iterator& operator--() { return --k_, *this; }
    const_iterator operator--(int) { return const_iterator(list_, k_--); }
    const_iterator& operator+=(difference_type n) { return k_ += n, *this; }
    const_iterator& operator-=(difference_type n) { return k_ -= n, *this; }
    const_iterator operator+(difference_type n) const { return const_iterator(list_, k_ + n); }
    const_iterator operator-(difference_type n) const { return const_iterator(list_, k_ - n); }
    friend const_iterator operator+(difference_type n, const const_iterator& it) { return it + n; }
    difference_type operator-(const const_iterator& o) const {
      return static_cast<difference_type>(k_) - static_cast<difference_type>(o.k_);
    }
    bool operator==(const const_iterator& o) const { return k_ == o.k_; }
    bool operator!=(const const_iterator& o) const { return k_ != o.k_; }
    bool operator<(const const_iterator& o) const { return k_ < o.k_; }
    bool operator>(const const_iterator& o) const { return k_ > o.k_; }
    bool operator<=(const const_iterator& o) const { return k_ <= o.k_; }
    bool operator>=(const const_iterator& o) const { return k_ >= o.k_; }

   private:
    friend class EdgeList;
    const_iterator(const EdgeList* list, size_t k) : list_(list), k_(k) {}
    const EdgeList* list_ = nullptr;
    size_t k_ = 0;
  };

  explicit EdgeList(int dimension);
  size_t size() const { return heads_.size(); }
  bool empty() const { return heads_.empty(); }
  Edge operator[](size_t k) const;
  Edge at(size_t k) const;  // throws std::out_of_range
  Edge front() const { return (*this)[0]; }
  Edge back() const { return (*this)[size() - 1]; }
  const_iterator begin() const { return const_iterator(this, 0); }
  const_iterator end() const { return const_iterator(this, size()); }
  // Without decoding the rest of the edge.
  EdgeKind kind(size_t k) const { return heads_[k].kind; }

  // Appended as given, without PoseGraph::AddEdge's checks (a graph's own
  // list takes edges only through it).
  void Reserve(size_t n);
  void Push(const Edge& e);

 private:
  friend class PoseGraph;
  struct Head {
    int64_t from, to;
    int32_t offset;
    EdgeKind kind;
  };
  void Set(size_t k, const Edge& e);
  void Keep(const std::vector<bool>& keep);
  // Doubles of z and of the information's triangle an edge of this kind uses.
  int MeasurementSize(EdgeKind kind) const;
  int InformationSize(EdgeKind kind) const;
  void Encode(const Edge& e, double* v) const;

  uint32_t Intern(const Edge& e);

  int dimension_;
  size_t stride_;       // measurement doubles an edge: 3 in 2D, 7 in 3D
  size_t info_stride_;  // doubles a triangle: 6 in 2D, 21 in 3D
  std::vector<Head, MappedAllocator<Head>> heads_;
  std::vector<double, MappedAllocator<double>> values_;
  std::vector<uint32_t, MappedAllocator<uint32_t>> info_;  // per edge, into infos_
  std::vector<double, MappedAllocator<double>> infos_;     // the distinct triangles
  static constexpr int kRecent = 8;
  uint32_t recent_[kRecent] = {};  // the last triangles stored or matched
  int recent_count_ = 0, recent_next_ = 0;
};

// A line of a file kept as it was, not interpreted (a tag cairn does not
// know, read with ReadOptions::keep_unknown): it stood after the first
// `vertices_before` vertices and `edges_before` edges, and the g2o writer puts
// it back there.
struct VerbatimLine {
  size_t vertices_before = 0;
  size_t edges_before = 0;
  std::string text;
};

// Indefinite information matrices replaced by their nearest positive
// semi-definite ones: how many, and the largest change, as the magnitude of
// the most negative eigenvalue clipped relative to that matrix's largest.
struct InformationRepairs {
  size_t matrices = 0;
  double largest_clipped = 0;
  size_t largest_line = 0;  // the file line of that matrix (0: none)
};

// Vertex ids to positions in the graph's vertex list. While the ids are
// dense (g2o files number them 0..N-1, or nearly) a plain array of 4 bytes
// an id, at most twice the id range; once they are not, a hash map (40
// bytes a vertex: at a million poses the array saves 36 MB).
class VertexIndex {
 public:
  bool Contains(int64_t id) const { return Find(id) != kAbsent; }
  // Throws std::out_of_range if absent.
  size_t At(int64_t id) const;
  // `id` must be new.
  void Insert(int64_t id, size_t position);

 private:
  static constexpr size_t kAbsent = ~size_t{0};
  size_t Find(int64_t id) const;
  bool InsertDense(int64_t id, size_t position);
  void ToSparse();
  bool dense_ = true;
  int64_t base_ = 0;             // the id of slots_[0]
  int64_t low_ = 0, high_ = 0;   // the smallest and largest id held
  std::vector<uint32_t> slots_;  // position + 1 of id base_ + k; 0: none
  size_t count_ = 0;
  std::unordered_map<int64_t, size_t> sparse_;
};

class PoseGraph {
 public:
  explicit PoseGraph(int dimension = 2);

  int dimension() const { return dimension_; }
  // Doubles in one pose's parameter block: 3 (SE2) or 7 (SE3).
  int ParameterSize() const { return dimension_ == 2 ? 3 : 7; }
  // Degrees of freedom of one pose: 3 (SE2) or 6 (SE3).
  int TangentSize() const { return dimension_ == 2 ? 3 : 6; }
  // A vertex's parameter block: a pose's size, or a point's (2 or 3, no
  // manifold: its tangent size too).
  int BlockSize(const Vertex& v) const { return v.landmark ? dimension_ : ParameterSize(); }
  int BlockTangentSize(const Vertex& v) const { return v.landmark ? dimension_ : TangentSize(); }
  // Rows of an edge's residual: a pose's tangent size, or a point's size.
  int ResidualSize(EdgeKind kind) const { return IsLandmarkKind(kind) ? dimension_ : TangentSize(); }
  int ResidualSize(const Edge& e) const { return ResidualSize(e.kind); }

  // Throws std::invalid_argument on a duplicate id. References to vertices
  // stay valid as the graph grows (solvers keep pointers to the parameters).
  Vertex& AddVertex(int64_t id, const PoseParams& x, bool fixed = false);
  Vertex& AddVertex(int64_t id, const SE2& pose, bool fixed = false);
  Vertex& AddVertex(int64_t id, const SE3& pose, bool fixed = false);
  // A point landmark at p (2D: p.z ignored).
  Vertex& AddLandmark(int64_t id, const Eigen::Vector3d& p, bool fixed = false);
  // Throws std::invalid_argument when an endpoint is missing or of the
  // wrong sort (a pose where the edge needs a point, or the reverse), a 3D
  // observation's offset is not defined, the information matrix is not
  // symmetric positive semi-definite (or is zero, or not finite), or a
  // between-edge joins a vertex to itself. A singular one is taken: a
  // direction of the error it gives no weight (a position-only prior) is
  // left to the other edges (solvers/determinacy.h).
  void AddEdge(const Edge& edge);

  // Sensor offsets of 3D landmark observations (g2o's PARAMS_SE3OFFSET), by
  // id: the observation is made from pose * offset.
  void SetOffset(int32_t id, const SE3& offset);
  bool HasOffset(int32_t id) const { return offsets_.count(id) != 0; }
  const SE3& offset(int32_t id) const { return offsets_.at(id); }
  const std::map<int32_t, SE3>& offsets() const { return offsets_; }

  bool HasVertex(int64_t id) const { return index_.Contains(id); }
  // Position of a vertex in vertices(); throws std::out_of_range if absent.
  size_t VertexIndex(int64_t id) const { return index_.At(id); }
  Vertex& vertex(int64_t id) { return vertices_[index_.At(id)]; }
  const Vertex& vertex(int64_t id) const { return vertices_[index_.At(id)]; }

  std::deque<Vertex>& vertices() { return vertices_; }
  const std::deque<Vertex>& vertices() const { return vertices_; }
  const EdgeList& edges() const { return edges_; }
  // Edge k replaced, without AddEdge's checks (the caller's edit of an
  // edge it took from edges(); its unused parts are dropped as AddEdge does).
  void SetEdge(size_t k, const Edge& edge);
  // Only the edges k with keep[k], in their order.
  void KeepEdges(const std::vector<bool>& keep);
  void ReserveEdges(size_t n) { edges_.Reserve(n); }

  size_t CountEdges(EdgeKind kind) const;
  size_t CountFixed() const;
  size_t CountLandmarks() const { return landmarks_; }
  bool HasLandmarks() const { return landmarks_ != 0; }

  // Lines carried through unchanged from the file read, in file order.
  const std::vector<VerbatimLine>& verbatim_lines() const { return verbatim_lines_; }
  void AddVerbatimLine(VerbatimLine line) { verbatim_lines_.push_back(std::move(line)); }

  // The information block that applies to this graph's dimension.
  Eigen::MatrixXd Information(const Edge& e) const;

  // What the reader changed to make indefinite information usable
  // (ReadOptions::repair_information); all zero when nothing.
  const InformationRepairs& information_repairs() const { return repairs_; }
  void set_information_repairs(const InformationRepairs& r) { repairs_ = r; }

 private:
  int dimension_;
  std::deque<Vertex> vertices_;
  cairn::VertexIndex index_;
  EdgeList edges_;
  std::vector<VerbatimLine> verbatim_lines_;
  size_t landmarks_ = 0;
  std::map<int32_t, SE3> offsets_;
  InformationRepairs repairs_;
};

// For code that treats every vertex as a pose (plots, trajectory errors,
// outlier rejection, ...): throws std::invalid_argument saying that `what`
// does not handle landmarks when the graph has any.
void RequireNoLandmarks(const PoseGraph& graph, const std::string& what);

SE2 ToSE2(const PoseParams& p);
SE3 ToSE3(const PoseParams& p);
PoseParams ToParams(const SE2& pose);
PoseParams ToParams(const SE3& pose);

// ToSE2 or ToSE3 by type, for code written once for both dimensions.
template <typename Pose>
Pose ToPose(const PoseParams& p) {
  if constexpr (std::is_same_v<Pose, SE2>) {
    return ToSE2(p);
  } else {
    return ToSE3(p);
  }
}

// The kind g2o files imply: consecutive ids are odometry, others loop closures.
EdgeKind KindForBetween(int64_t from, int64_t to);

// True when `info` is symmetric (to a relative 1e-9) and positive definite.
bool IsSymmetricPositiveDefinite(const Eigen::MatrixXd& info);

// An information matrix as the solvers see it. Eigenvalues down to
// -kSemiDefiniteTolerance times the largest count as zero (rounding in a
// file written from a singular matrix).
enum class InformationClass { kPositiveDefinite, kSingular, kIndefinite, kUnusable };
constexpr double kSemiDefiniteTolerance = 1e-9;
// kUnusable: not finite, not symmetric to a relative 1e-9, or zero. When
// `smallest` is given and the matrix is not positive definite, it gets the
// smallest eigenvalue over the largest in magnitude.
InformationClass ClassifyInformation(const Eigen::MatrixXd& info, double* smallest = nullptr);
// Replaces a symmetric `info` by the nearest positive semi-definite matrix
// (Frobenius norm: its eigenvalues clipped at zero) and returns the most
// negative eigenvalue's magnitude relative to the largest (0 if none).
double ClipToSemiDefinite(Eigen::MatrixXd* info);

// Vertex ids of each connected component (between-edges and landmark
// observations: poses that see a common landmark are one component), each
// sorted, components ordered by their lowest id. Without
// `through_landmarks`, between-edges only (each landmark alone).
std::vector<std::vector<int64_t>> ConnectedComponents(const PoseGraph& graph,
                                                      bool through_landmarks = true);

// The pose at one end of between-edge `e`, chained from the pose at the
// other: e.to's from e.from's pose when `forward`, else e.from's from e.to's.
PoseParams ChainMeasurement(const PoseGraph& graph, const Edge& e, const PoseParams& from_pose,
                            bool forward);

// The point pose X observes with landmark edge e: X * z in 2D, X * offset *
// z in 3D.
Eigen::Vector3d ObservedPoint(const PoseGraph& graph, const Edge& e, const PoseParams& pose);

// Places every landmark that is not fixed at its first observation (in edge
// order) from the observing pose's current estimate; a landmark no edge
// observes keeps its estimate. Every initialiser ends with this.
void PlaceLandmarks(PoseGraph& graph);

// Sets every vertex's estimate by chaining measurements outward along a
// spanning tree that prefers the most certain edges (largest information
// trace). Each component starts at its fixed vertex if it has one, else at
// its lowest id, which keeps its current pose. Priors are not followed; a
// point cannot place a pose, so poses tied only through landmarks start
// trees of their own; landmarks then by PlaceLandmarks. What a file without
// vertices is placed by (graph_io.h).
void ChainAlongSpanningTree(PoseGraph& graph);

}  // namespace cairn
