// The pose graph: vertices (robot poses) and edges (odometry, loop closures,
// priors) with their measurements and information matrices, and what
// follows from the graph alone (its connected components, measurements
// chained along a spanning tree). One graph is either planar (SE2) or
// spatial (SE3), never both.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <deque>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cairn/graph/geometry.h"

namespace cairn {

enum class EdgeKind { kOdometry, kLoopClosure, kPrior };
const char* ToString(EdgeKind kind);

// A pose's parameters, laid out as g2o writes them: (x, y, theta) in 2D,
// (x, y, z, qx, qy, qz, qw) in 3D. Solvers optimise these arrays in place.
using PoseParams = std::array<double, 7>;

struct Vertex {
  int64_t id = 0;
  PoseParams x{};
  bool fixed = false;
};

struct Edge {
  EdgeKind kind = EdgeKind::kOdometry;
  int64_t from = 0;  // the constrained vertex of a prior
  int64_t to = -1;   // unused by a prior
  PoseParams z{};    // measurement, laid out like a vertex
  Matrix6d information = Matrix6d::Identity();  // 2D: top-left 3x3, rest zero once added

  bool IsPrior() const { return kind == EdgeKind::kPrior; }
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

class PoseGraph {
 public:
  explicit PoseGraph(int dimension = 2);

  int dimension() const { return dimension_; }
  // Doubles in one pose's parameter block: 3 (SE2) or 7 (SE3).
  int ParameterSize() const { return dimension_ == 2 ? 3 : 7; }
  // Degrees of freedom of one pose: 3 (SE2) or 6 (SE3).
  int TangentSize() const { return dimension_ == 2 ? 3 : 6; }

  // Throws std::invalid_argument on a duplicate id. References to vertices
  // stay valid as the graph grows (solvers keep pointers to the parameters).
  Vertex& AddVertex(int64_t id, const PoseParams& x, bool fixed = false);
  Vertex& AddVertex(int64_t id, const SE2& pose, bool fixed = false);
  Vertex& AddVertex(int64_t id, const SE3& pose, bool fixed = false);
  // Throws std::invalid_argument when an endpoint is missing, the
  // information matrix is not symmetric positive semi-definite (or is zero,
  // or not finite), or a between-edge joins a vertex to itself. A singular
  // one is taken: a direction of the error it gives no weight (a
  // position-only prior) is left to the other edges (solvers/determinacy.h).
  void AddEdge(const Edge& edge);

  bool HasVertex(int64_t id) const { return index_.count(id) != 0; }
  // Position of a vertex in vertices(); throws std::out_of_range if absent.
  size_t VertexIndex(int64_t id) const { return index_.at(id); }
  Vertex& vertex(int64_t id) { return vertices_[index_.at(id)]; }
  const Vertex& vertex(int64_t id) const { return vertices_[index_.at(id)]; }

  std::deque<Vertex>& vertices() { return vertices_; }
  const std::deque<Vertex>& vertices() const { return vertices_; }
  const std::vector<Edge>& edges() const { return edges_; }
  std::vector<Edge>& mutable_edges() { return edges_; }

  size_t CountEdges(EdgeKind kind) const;
  size_t CountFixed() const;

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
  std::unordered_map<int64_t, size_t> index_;
  std::vector<Edge> edges_;
  std::vector<VerbatimLine> verbatim_lines_;
  InformationRepairs repairs_;
};

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

// Vertex ids of each connected component (between-edges only), each sorted,
// components ordered by their lowest id.
std::vector<std::vector<int64_t>> ConnectedComponents(const PoseGraph& graph);

// The pose at one end of between-edge `e`, chained from the pose at the
// other: e.to's from e.from's pose when `forward`, else e.from's from e.to's.
PoseParams ChainMeasurement(const PoseGraph& graph, const Edge& e, const PoseParams& from_pose,
                            bool forward);

// Sets every vertex's estimate by chaining measurements outward along a
// spanning tree that prefers the most certain edges (largest information
// trace). Each component starts at its fixed vertex if it has one, else at
// its lowest id, which keeps its current pose. Priors are not followed.
// What a file without vertices is placed by (graph_io.h).
void ChainAlongSpanningTree(PoseGraph& graph);

}  // namespace cairn
