#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"

#include <deque>
#include <unistd.h>

#include <cctype>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "cairn/graph/mapped_allocator.h"
#include "cairn/graph/pose_graph.h"

namespace cairn {

namespace {

// One line's fields, with number parsing that reports where it went wrong.
class Fields {
 public:
  Fields(std::vector<std::string> tokens, const std::string& file, size_t line)
      : tokens_(std::move(tokens)), file_(file), line_(line) {}

  const std::string& tag() const { return tokens_[0]; }
  size_t size() const { return tokens_.size() - 1; }
  size_t line() const { return line_; }

  [[noreturn]] void Fail(const std::string& message) const {
    throw ParseError(file_, line_, message);
  }

  void ExpectCount(size_t n) const {
    if (size() < n)
      Fail(tag() + " needs " + std::to_string(n) + " fields, found " + std::to_string(size()));
    if (size() > n)
      Fail(tag() + " takes " + std::to_string(n) + " fields, found " + std::to_string(size()) +
           " (extra: '" + tokens_[n + 1] + "')");
  }
  void ExpectAtLeast(size_t n) const {
    if (size() < n)
      Fail(tag() + " needs at least " + std::to_string(n) + " fields, found " +
           std::to_string(size()));
  }

  // Field k (1-based after the tag) as a finite double.
  double Number(size_t k, const char* what) const {
    const std::string& s = tokens_[k];
    // from_chars rounds as strtod does, several times faster; anything it
    // does not take whole ('+1', hex, out of range) goes the strtod way
    // below, which decides what is accepted.
    double fast = 0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), fast);
    if (ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(fast)) return fast;
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0')
      Fail(std::string("expected a number for ") + what + ", found '" + s + "'");
    if (std::isnan(v)) Fail(std::string(what) + " is NaN");
    if (std::isinf(v) || (errno == ERANGE && std::fabs(v) > 1)) {
      Fail(std::string(what) + " is out of range ('" + s + "')");
    }
    return v;
  }

  // Field k as an angle in radians, within the sane range.
  double Angle(size_t k, const char* what) const {
    const double v = Number(k, what);
    CheckRange(v, kMaxAbsAngle, what, " rad");
    return v;
  }

  void CheckRange(double v, double bound, const char* what, const char* unit) const {
    if (std::fabs(v) <= bound) return;
    char buf[128];
    std::snprintf(buf, sizeof buf, "%s %g%s is out of range (at most %g in magnitude)", what, v,
                  unit, bound);
    Fail(buf);
  }

  // Field k as a vertex id: a non-negative integer that fits in an int.
  int64_t Id(size_t k) const {
    const std::string& s = tokens_[k];
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(s.c_str(), &end, 10);
    if (end == s.c_str() || *end != '\0') Fail("expected a vertex id, found '" + s + "'");
    if (errno == ERANGE || v < 0 || v > std::numeric_limits<int32_t>::max())
      Fail("vertex id " + s + " is out of range (0 to 2147483647)");
    return v;
  }

 private:
  std::vector<std::string> tokens_;
  const std::string& file_;
  size_t line_;
};

// Normalises a quaternion read from a file: zero is refused, a small
// deviation from unit length (rounding in the file) is corrected, a large
// one is refused. Exactly-unit quaternions are left bit for bit.
void CheckQuaternion(const Fields& f, double* q) {
  const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(n2 > 1e-20)) f.Fail("zero quaternion");
  const double n = std::sqrt(n2);
  if (std::fabs(n - 1.0) > 1e-2)
    f.Fail("quaternion is far from unit length (norm " + std::to_string(n) + ")");
  if (std::fabs(n2 - 1.0) > 8 * std::numeric_limits<double>::epsilon())
    for (int i = 0; i < 4; ++i) q[i] /= n;
}

// Reads an upper triangle row by row into a symmetric n x n block.
void ReadUpperTriangle(const Fields& f, size_t first, int n, Matrix6d* info) {
  info->setZero();
  size_t k = first;
  for (int r = 0; r < n; ++r)
    for (int c = r; c < n; ++c) {
      const double v = f.Number(k++, "an information entry");
      (*info)(r, c) = (*info)(c, r) = v;
    }
}

// A singular information matrix is taken (a position-only prior); an
// indefinite one is refused, or with `repairs` replaced by the nearest
// positive semi-definite one and counted there.
void CheckInformation(const Fields& f, Matrix6d* info, int n, InformationRepairs* repairs) {
  Eigen::MatrixXd block = info->topLeftCorner(n, n);
  double smallest = 0;
  switch (ClassifyInformation(block, &smallest)) {
    case InformationClass::kPositiveDefinite:
    case InformationClass::kSingular: return;
    case InformationClass::kUnusable:
      f.Fail("information matrix is " +
             std::string(!block.allFinite() ? "not finite"
                         : block.cwiseAbs().maxCoeff() > 0 ? "not symmetric" : "zero"));
    case InformationClass::kIndefinite: break;
  }
  if (!repairs) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "information matrix is indefinite (smallest eigenvalue %.3g times the "
                  "largest); --repair-information replaces it by the nearest positive "
                  "semi-definite matrix",
                  smallest);
    f.Fail(buf);
  }
  const double clipped = ClipToSemiDefinite(&block);
  if (ClassifyInformation(block) == InformationClass::kUnusable)
    f.Fail("information matrix has no positive eigenvalue: nothing is left once repaired");
  info->topLeftCorner(n, n) = block;
  ++repairs->matrices;
  if (clipped > repairs->largest_clipped) {
    repairs->largest_clipped = clipped;
    repairs->largest_line = f.line();
  }
}

// The same, into an edge's packed information.
void ReadUpperTriangle(const Fields& f, size_t first, int n, SymmetricMatrix6* info) {
  Matrix6d m = info->Full();
  ReadUpperTriangle(f, first, n, &m);
  *info = m;
}

void CheckInformation(const Fields& f, SymmetricMatrix6* info, int n, InformationRepairs* repairs) {
  Matrix6d m = info->Full();
  CheckInformation(f, &m, n, repairs);
  *info = m;
}

// TORO's 2D order is (xx, xy, yy, tt, xt, yt).
Matrix6d ToroInformation2D(const Fields& f, size_t first) {
  const double xx = f.Number(first, "an information entry");
  const double xy = f.Number(first + 1, "an information entry");
  const double yy = f.Number(first + 2, "an information entry");
  const double tt = f.Number(first + 3, "an information entry");
  const double xt = f.Number(first + 4, "an information entry");
  const double yt = f.Number(first + 5, "an information entry");
  Matrix6d info = Matrix6d::Zero();
  info.topLeftCorner<3, 3>() << xx, xy, xt, xy, yy, yt, xt, yt, tt;
  return info;
}

struct PendingEdge {
  Edge edge;
  size_t line;
};

// Edges read, waiting until every vertex is known, with their lines; in
// chunks of kEdges, each of whose arrays is mapped on its own (from 128 KiB,
// MappedAllocator) and goes back to the system once moved into the graph.
struct PendingChunk {
  static constexpr size_t kEdges = size_t{1} << 14;
  explicit PendingChunk(int dimension) : edges(dimension) {
    edges.Reserve(kEdges);
    lines.reserve(kEdges);
  }
  EdgeList edges;
  std::vector<size_t, MappedAllocator<size_t>> lines;
};

bool LooksBinary(const std::string& line) {
  for (unsigned char c : line)
    if (c == 0 || (c < 32 && c != '\t' && c != '\r' && c != '\v' && c != '\f')) return true;
  return false;
}

// The "C" locale's white space, which std::isspace gives at a call's cost.
inline bool IsSpace(char c) { return c == ' ' || (c >= '\t' && c <= '\r'); }

// Splits on the whitespace operator>> skips; by hand, since a string stream
// per line dominated the time to read large files.
std::vector<std::string> Tokenize(const std::string& line) {
  std::vector<std::string> out;
  const char* p = line.c_str();
  const char* end = p + line.size();
  while (p < end) {
    while (p < end && IsSpace(*p)) ++p;
    const char* start = p;
    while (p < end && !IsSpace(*p)) ++p;
    if (p > start) out.emplace_back(start, p);
  }
  return out;
}

class Reader {
 public:
  Reader(const std::string& name, const ReadOptions& options) : name_(name), options_(options) {}

  void Line(const std::string& raw, size_t line_no) {
    if (LooksBinary(raw)) throw ParseError(name_, line_no, "binary data, not a pose-graph file");
    std::string line = raw;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    auto tokens = Tokenize(line);
    if (tokens.empty()) return;
    Fields f(std::move(tokens), name_, line_no);
    if (ReadVertex(f) || ReadBetween(f) || ReadPrior(f) || ReadLandmark(f) ||
        ReadObservation(f) || ReadOther(f))
      return;
    Unknown(f, raw);
  }

  PoseGraph Finish(size_t lines) {
    if (dimension_ == 0) throw ParseError(name_, lines, "empty file: no vertices or edges");
    PoseGraph& graph = *graph_;
    const bool edges_only = graph.vertices().empty();
    for (const auto& [id, p] : offsets_) graph.SetOffset(static_cast<int32_t>(id), ToSE3(p));
    if (edges_only) AddEndpoints(graph);
    // Edges move from the pending chunks into the graph, each chunk released
    // once moved: a large file's edges are held about once, not twice, at
    // the peak.
    graph.ReserveEdges(edge_count_);
    for (PendingChunk& chunk : edge_chunks_) {
      for (size_t k = 0; k < chunk.edges.size(); ++k) {
        const PendingEdge p{chunk.edges[k], chunk.lines[k]};
        for (int64_t id : {p.edge.from, p.edge.to}) {
          if (id == p.edge.to && p.edge.IsPrior()) continue;
          if (!graph.HasVertex(id))
            throw ParseError(name_, p.line,
                             "edge to vertex " + std::to_string(id) + ", which does not exist");
        }
        if (!p.edge.IsPrior() && p.edge.from == p.edge.to)
          throw ParseError(name_, p.line,
                           "edge joins vertex " + std::to_string(p.edge.from) + " to itself");
        try {
          graph.AddEdge(p.edge);  // the sort of each endpoint is checked there
        } catch (const std::invalid_argument& e) {
          throw ParseError(name_, p.line, e.what());
        }
      }
      chunk.edges = EdgeList(dimension_);
      std::vector<size_t, MappedAllocator<size_t>>().swap(chunk.lines);
    }
    for (const auto& [id, line] : fixed_) {
      if (!graph.HasVertex(id))
        throw ParseError(name_, line, "FIX names vertex " + std::to_string(id) + ", which does not exist");
      graph.vertex(id).fixed = true;
    }
    for (VerbatimLine& l : graph_lines_) graph.AddVerbatimLine(std::move(l));
    graph.set_information_repairs(repairs_);
    if (edges_only) ChainAlongSpanningTree(graph);
    return std::move(graph);
  }

 private:
  // Each Read* takes the line when its tag is one of its family's, and says
  // whether it did.

  // VERTEX_SE2 (TORO's VERTEX2), VERTEX_SE3:QUAT, TORO's VERTEX3.
  bool ReadVertex(const Fields& f) {
    const std::string& tag = f.tag();
    if (tag == "VERTEX_SE2" || tag == "VERTEX2") {
      SetDimension(f, 2);
      f.ExpectCount(4);
      AddVertex(f, {f.Number(2, "x"), f.Number(3, "y"), f.Number(4, "theta"), 0, 0, 0, 0});
    } else if (tag == "VERTEX_SE3:QUAT") {
      SetDimension(f, 3);
      f.ExpectCount(8);
      PoseParams p{};
      for (int i = 0; i < 7; ++i) p[i] = f.Number(2 + i, i < 3 ? "a translation" : "a quaternion");
      CheckQuaternion(f, &p[3]);
      AddVertex(f, p);
    } else if (tag == "VERTEX3") {
      SetDimension(f, 3);
      f.ExpectCount(7);
      Vector6d v;
      for (int i = 0; i < 6; ++i) v[i] = i < 3 ? f.Number(2 + i, "a translation") : f.Angle(2 + i, "an angle");
      AddVertex(f, ToParams(SE3::FromEulerVector(v)));
    } else {
      return false;
    }
    return true;
  }

  // EDGE_SE2 (TORO's EDGE2), EDGE_SE3:QUAT, TORO's EDGE3.
  bool ReadBetween(const Fields& f) {
    const std::string& tag = f.tag();
    Edge e;
    if (tag == "EDGE_SE2" || tag == "EDGE2") {
      SetDimension(f, 2);
      f.ExpectCount(11);
      e = Between(f);
      e.z = {f.Number(3, "dx"), f.Number(4, "dy"), f.Number(5, "dtheta"), 0, 0, 0, 0};
      if (tag == "EDGE_SE2") {
        ReadUpperTriangle(f, 6, 3, &e.information);
      } else {
        e.information = ToroInformation2D(f, 6);
      }
      CheckInformation(f, &e.information, 3, Repairs());
    } else if (tag == "EDGE_SE3:QUAT") {
      SetDimension(f, 3);
      f.ExpectCount(30);
      e = Between(f);
      for (int i = 0; i < 7; ++i) e.z[i] = f.Number(3 + i, i < 3 ? "a translation" : "a quaternion");
      CheckQuaternion(f, &e.z[3]);
      ReadUpperTriangle(f, 10, 6, &e.information);
      CheckInformation(f, &e.information, 6, Repairs());
    } else if (tag == "EDGE3") {
      SetDimension(f, 3);
      f.ExpectCount(29);
      e = Between(f);
      ReadToroEdge3D(f, &e);
    } else {
      return false;
    }
    AddEdge(f, e);
    return true;
  }

  // EDGE3's measurement and information, its angles and weights turned into g2o's.
  void ReadToroEdge3D(const Fields& f, Edge* e) {
    Vector6d v;
    for (int i = 0; i < 6; ++i) v[i] = i < 3 ? f.Number(3 + i, "a translation") : f.Angle(3 + i, "an angle");
    e->z = ToParams(SE3::FromEulerVector(v));
    Matrix6d rpy;
    ReadUpperTriangle(f, 9, 6, &rpy);
    CheckInformation(f, &rpy, 6, Repairs());
    // TORO weighs small roll-pitch-yaw errors; g2o's rotation error is the
    // quaternion's vector part, about half the angles: Omega_q = J^T Omega J
    // with J = diag(I, 2I).
    Vector6d j;
    j << 1, 1, 1, 2, 2, 2;
    e->information = j.asDiagonal() * rpy * j.asDiagonal();
  }

  // No VERTEX lines: every endpoint becomes a vertex (a landmark when an
  // observation or a point prior names it), placed later by chaining the
  // measurements. An id used as both is an error at the line that shows it.
  void AddEndpoints(PoseGraph& graph) {
    std::map<int64_t, std::pair<bool, size_t>> ids;  // id -> (landmark, first line)
    auto note = [&](int64_t id, bool landmark, size_t line) {
      const auto [it, fresh] = ids.emplace(id, std::make_pair(landmark, line));
      if (!fresh && it->second.first != landmark)
        throw ParseError(name_, line,
                         "vertex " + std::to_string(id) + " is used as a " +
                             (landmark ? "landmark" : "pose") + " here and as a " +
                             (landmark ? "pose" : "landmark") + " on line " +
                             std::to_string(it->second.second));
    };
    for (const PendingChunk& chunk : edge_chunks_)
      for (size_t k = 0; k < chunk.edges.size(); ++k) {
        const PendingEdge p{chunk.edges[k], chunk.lines[k]};
        note(p.edge.from, p.edge.kind == EdgeKind::kLandmarkPrior, p.line);
        if (!p.edge.IsPrior()) note(p.edge.to, p.edge.kind == EdgeKind::kLandmark, p.line);
      }
    for (const auto& [id, sort] : ids) {
      if (sort.first) {
        graph.AddLandmark(id, Eigen::Vector3d::Zero());
      } else {
        graph.AddVertex(id, graph.dimension() == 2 ? ToParams(SE2()) : ToParams(SE3()));
      }
    }
  }

  // VERTEX_XY, VERTEX_TRACKXYZ: point landmarks.
  bool ReadLandmark(const Fields& f) {
    const int dim = f.tag() == "VERTEX_XY" ? 2 : f.tag() == "VERTEX_TRACKXYZ" ? 3 : 0;
    if (dim == 0) return false;
    SetDimension(f, dim);
    f.ExpectCount(1 + dim);
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int i = 0; i < dim; ++i) {
      p[i] = f.Number(2 + i, "a coordinate");
      f.CheckRange(p[i], kMaxAbsCoordinate, "coordinate", "");
    }
    const int64_t id = f.Id(1);
    if (graph_->HasVertex(id)) f.Fail("duplicate vertex id " + std::to_string(id));
    graph_->AddLandmark(id, p);
    return true;
  }

  // EDGE_SE2_XY, EDGE_SE3_TRACKXYZ (through a PARAMS_SE3OFFSET), and the
  // point priors EDGE_PRIOR_XY, EDGE_POINTXYZ_PRIOR.
  bool ReadObservation(const Fields& f) {
    const std::string& tag = f.tag();
    const bool prior = tag == "EDGE_PRIOR_XY" || tag == "EDGE_POINTXYZ_PRIOR";
    const int dim = tag == "EDGE_SE2_XY" || tag == "EDGE_PRIOR_XY"              ? 2
                    : tag == "EDGE_SE3_TRACKXYZ" || tag == "EDGE_POINTXYZ_PRIOR" ? 3
                                                                                 : 0;
    if (dim == 0) return false;
    SetDimension(f, dim);
    const size_t info = dim == 2 ? 3 : 6;
    const bool offset = tag == "EDGE_SE3_TRACKXYZ";
    const size_t first = (prior ? 2 : 3) + (offset ? 1 : 0);  // of the measurement
    f.ExpectCount(first - 1 + dim + info);
    Edge e;
    e.kind = prior ? EdgeKind::kLandmarkPrior : EdgeKind::kLandmark;
    e.from = f.Id(1);
    e.to = prior ? -1 : f.Id(2);
    if (offset) {
      const int64_t param = f.Id(3);
      if (offsets_.count(param) == 0)
        f.Fail(tag + " names parameter " + std::to_string(param) +
               ", which no PARAMS_SE3OFFSET line before it defines");
      e.offset = static_cast<int32_t>(param);
    }
    for (int i = 0; i < dim; ++i) {
      e.z[i] = f.Number(first + i, "a coordinate");
      f.CheckRange(e.z[i], kMaxAbsCoordinate, "coordinate", "");
    }
    ReadUpperTriangle(f, first + dim, dim, &e.information);
    CheckInformation(f, &e.information, dim, Repairs());
    PushEdge(f, e);
    return true;
  }

  // EDGE_PRIOR_SE2, EDGE_SE3_PRIOR (through an identity PARAMS_SE3OFFSET only).
  bool ReadPrior(const Fields& f) {
    const std::string& tag = f.tag();
    Edge e;
    if (tag == "EDGE_PRIOR_SE2") {
      SetDimension(f, 2);
      f.ExpectCount(10);
      e = Prior(f);
      e.z = {f.Number(2, "x"), f.Number(3, "y"), f.Number(4, "theta"), 0, 0, 0, 0};
      ReadUpperTriangle(f, 5, 3, &e.information);
      CheckInformation(f, &e.information, 3, Repairs());
    } else if (tag == "EDGE_SE3_PRIOR") {
      SetDimension(f, 3);
      f.ExpectCount(30);
      e = Prior(f);
      const int64_t param = f.Id(2);
      auto it = offsets_.find(param);
      if (it == offsets_.end())
        f.Fail("EDGE_SE3_PRIOR names parameter " + std::to_string(param) +
               ", which no PARAMS_SE3OFFSET line defines");
      if (!IsIdentity(it->second))
        f.Fail("EDGE_SE3_PRIOR with a non-identity sensor offset is not supported");
      for (int i = 0; i < 7; ++i) e.z[i] = f.Number(3 + i, i < 3 ? "a translation" : "a quaternion");
      CheckQuaternion(f, &e.z[3]);
      ReadUpperTriangle(f, 10, 6, &e.information);
      CheckInformation(f, &e.information, 6, Repairs());
    } else if (tag == "EDGE_SE3_XYZPRIOR") {
      e = TranslationPrior(f);
    } else {
      return false;
    }
    AddEdge(f, e);
    return true;
  }

  // EDGE_SE3_XYZPRIOR ID PARAM x y z info(6): g2o's error t - z, which is
  // EDGE_SE3_PRIOR's with an identity rotation measured and no weight on
  // rotation (the offset does not enter g2o's error): a position-only prior.
  Edge TranslationPrior(const Fields& f) {
    SetDimension(f, 3);
    f.ExpectCount(11);
    Edge e = Prior(f);
    const int64_t param = f.Id(2);
    if (offsets_.count(param) == 0)
      f.Fail("EDGE_SE3_XYZPRIOR names parameter " + std::to_string(param) +
             ", which no PARAMS_SE3OFFSET line defines");
    e.z = {0, 0, 0, 0, 0, 0, 1};
    for (int i = 0; i < 3; ++i) e.z[i] = f.Number(3 + i, "a translation");
    Matrix6d t = Matrix6d::Zero();
    ReadUpperTriangle(f, 6, 3, &t);
    CheckInformation(f, &t, 3, Repairs());
    e.information.SetTopLeft(t.topLeftCorner<3, 3>());
    return e;
  }

  // PARAMS_SE3OFFSET and FIX.
  bool ReadOther(const Fields& f) {
    if (f.tag() == "PARAMS_SE3OFFSET") {
      f.ExpectCount(8);
      double p[7];
      for (int i = 0; i < 7; ++i) p[i] = f.Number(2 + i, "an offset");
      CheckQuaternion(f, &p[3]);
      const int64_t id = f.Id(1);
      if (offsets_.count(id)) f.Fail("duplicate PARAMS_SE3OFFSET id " + std::to_string(id));
      PoseParams& o = offsets_[id];
      std::copy(p, p + 7, o.begin());
    } else if (f.tag() == "FIX") {
      f.ExpectAtLeast(1);
      for (size_t k = 1; k <= f.size(); ++k) fixed_.push_back({f.Id(k), f.line()});
    } else {
      return false;
    }
    return true;
  }

  void SetDimension(const Fields& f, int dim) {
    if (dimension_ == 0) {
      dimension_ = dim;
      first_line_ = f.tag();
      graph_.emplace(dim);
    } else if (dimension_ != dim) {
      f.Fail(f.tag() + " in a " + std::to_string(dimension_) + "D file (it began with " +
             first_line_ + "): SE2 and SE3 cannot be mixed");
    }
  }

  void AddVertex(const Fields& f, const PoseParams& x) {
    CheckPose(f, x, "theta");
    const int64_t id = f.Id(1);
    if (graph_->HasVertex(id)) f.Fail("duplicate vertex id " + std::to_string(id));
    graph_->AddVertex(id, x);
  }

  void AddEdge(const Fields& f, const Edge& e) {
    CheckPose(f, e.z, e.IsPrior() ? "theta" : "dtheta");
    PushEdge(f, e);
  }

  void PushEdge(const Fields& f, const Edge& e) {
    if (edge_chunks_.empty() || edge_chunks_.back().edges.size() == PendingChunk::kEdges)
      edge_chunks_.emplace_back(dimension_);
    edge_chunks_.back().edges.Push(e);
    edge_chunks_.back().lines.push_back(f.line());
    ++edge_count_;
  }

  // A pose's translation and (2D) heading within the sane ranges; 3D
  // rotations are unit quaternions by now, and TORO's angles were checked
  // as they were read.
  void CheckPose(const Fields& f, const PoseParams& x, const char* heading) const {
    for (int i = 0; i < (dimension_ == 2 ? 2 : 3); ++i)
      f.CheckRange(x[i], kMaxAbsCoordinate, "coordinate", "");
    if (dimension_ == 2) f.CheckRange(x[2], kMaxAbsAngle, heading, " rad");
  }

  // Skipping a line would lose what it says (and would hide a damaged
  // first tag): refuse it, or keep it verbatim when asked to.
  void Unknown(const Fields& f, const std::string& raw) {
    if (!options_.keep_unknown)
      f.Fail("unknown tag '" + f.tag() + "' (--keep-unknown keeps such lines verbatim)");
    graph_lines_.push_back({graph_ ? graph_->vertices().size() : 0, edge_count_, raw});
  }

  InformationRepairs* Repairs() { return options_.repair_information ? &repairs_ : nullptr; }

  Edge Between(const Fields& f) const {
    Edge e;
    e.from = f.Id(1);
    e.to = f.Id(2);
    e.kind = KindForBetween(e.from, e.to);
    return e;
  }

  Edge Prior(const Fields& f) const {
    Edge e;
    e.kind = EdgeKind::kPrior;
    e.from = f.Id(1);
    e.to = -1;
    return e;
  }

  std::string name_;
  ReadOptions options_;
  int dimension_ = 0;
  std::string first_line_;
  // Built as vertices are read (no second copy of them); edges wait until
  // every vertex is known.
  std::optional<PoseGraph> graph_;
  std::vector<PendingChunk> edge_chunks_;
  size_t edge_count_ = 0;
  std::vector<std::pair<int64_t, size_t>> fixed_;
  std::map<int64_t, PoseParams> offsets_;  // PARAMS_SE3OFFSET id -> offset

  static bool IsIdentity(const PoseParams& p) {
    return p[0] == 0 && p[1] == 0 && p[2] == 0 && std::fabs(p[6]) == 1.0;
  }
  std::vector<VerbatimLine> graph_lines_;
  InformationRepairs repairs_;
};

}  // namespace

PoseGraph ReadGraph(std::istream& in, const std::string& name, const ReadOptions& options) {
  Reader reader(name, options);
  TextInput input(in, name, options.max_line_bytes);
  std::string line;
  while (input.Next(&line)) reader.Line(line, input.line());
  return reader.Finish(input.line() == 0 ? 1 : input.line());
}

PoseGraph ReadGraph(const std::string& path, const ReadOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw std::runtime_error(path + ": is a directory, not a pose-graph file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  return ReadGraph(in, path, options);
}

namespace {

// " %.17g": std::to_chars with that format and precision writes what
// printf does, byte for byte, without printf's arbitrary-precision path
// (a tenth of a small file's whole run went to glibc's digit generation).
void WriteNumber(std::ostream& out, double v) {
  char buf[40];
  buf[0] = ' ';
  const auto r = std::to_chars(buf + 1, buf + sizeof buf, v, std::chars_format::general, 17);
  out.write(buf, r.ptr - buf);
}

void WriteNumbers(std::ostream& out, const double* v, int n) {
  for (int i = 0; i < n; ++i) WriteNumber(out, v[i]);
}

void WriteUpperTriangle(std::ostream& out, const Matrix6d& info, int n) {
  for (int r = 0; r < n; ++r)
    for (int c = r; c < n; ++c) WriteNumber(out, info(r, c));
}

// Writes the kept lines back where they stood: each before the first
// vertex or edge that followed it in the file.
class VerbatimWriter {
 public:
  VerbatimWriter(const PoseGraph& graph, std::ostream& out) : lines_(graph.verbatim_lines()), out_(out) {}
  // The lines that stood before vertex `vertices` and edge `edges`.
  void Before(size_t vertices, size_t edges) {
    for (; next_ < lines_.size() && lines_[next_].vertices_before <= vertices &&
           lines_[next_].edges_before <= edges;
         ++next_)
      out_ << lines_[next_].text << '\n';
  }
  void Rest() { Before(kAll, kAll); }
  static constexpr size_t kAll = std::numeric_limits<size_t>::max();

 private:
  const std::vector<VerbatimLine>& lines_;
  std::ostream& out_;
  size_t next_ = 0;
};


// The PARAMS_SE3OFFSET id the 3D priors are written through: an identity
// offset the graph has, else the lowest id it does not use; -1 without priors.
int64_t PriorOffsetId(const PoseGraph& graph, bool* write_it) {
  *write_it = false;
  bool has_se3_prior = false;
  for (const Edge& e : graph.edges()) has_se3_prior |= e.kind == EdgeKind::kPrior;
  if (graph.dimension() == 2 || !has_se3_prior) return -1;
  for (const auto& [id, o] : graph.offsets())
    if (o.translation().isZero(0) && std::fabs(o.rotation().w()) == 1.0) return id;
  int64_t id = 0;
  while (graph.HasOffset(static_cast<int32_t>(id))) ++id;
  *write_it = true;
  return id;
}

void WriteOffsets(const PoseGraph& graph, std::ostream& out, int64_t prior_id, bool write_prior) {
  for (const auto& [id, o] : graph.offsets()) {
    out << "PARAMS_SE3OFFSET " << id;
    WriteNumbers(out, o.ToVector().data(), 7);
    out << '\n';
  }
  if (write_prior) out << "PARAMS_SE3OFFSET " << prior_id << " 0 0 0 0 0 0 1\n";
}

void WriteVertex(const PoseGraph& graph, const Vertex& v, std::ostream& out) {
  const bool planar = graph.dimension() == 2;
  if (v.landmark) {
    out << (planar ? "VERTEX_XY " : "VERTEX_TRACKXYZ ") << v.id;
  } else {
    out << (planar ? "VERTEX_SE2 " : "VERTEX_SE3:QUAT ") << v.id;
  }
  WriteNumbers(out, v.x.data(), graph.BlockSize(v));
  out << '\n';
}

// A 3D prior that measures an identity rotation and weighs only the
// translation: what EDGE_SE3_XYZPRIOR says, and written so.
bool IsTranslationPrior(const PoseGraph& graph, const Edge& e) {
  return graph.dimension() == 3 && e.kind == EdgeKind::kPrior && e.z[3] == 0 && e.z[4] == 0 &&
         e.z[5] == 0 && e.z[6] == 1 && e.information.Full().bottomRows<3>().isZero(0);
}

void WriteEdge(const PoseGraph& graph, const Edge& e, int64_t prior_id, std::ostream& out) {
  const bool planar = graph.dimension() == 2;
  if (IsTranslationPrior(graph, e)) {
    out << "EDGE_SE3_XYZPRIOR " << e.from << ' ' << prior_id;
    WriteNumbers(out, e.z.data(), 3);
    WriteUpperTriangle(out, e.information, 3);
    out << '\n';
    return;
  }
  switch (e.kind) {
    case EdgeKind::kPrior:
      out << (planar ? "EDGE_PRIOR_SE2 " : "EDGE_SE3_PRIOR ") << e.from;
      if (!planar) out << ' ' << prior_id;
      break;
    case EdgeKind::kLandmarkPrior:
      out << (planar ? "EDGE_PRIOR_XY " : "EDGE_POINTXYZ_PRIOR ") << e.from;
      break;
    case EdgeKind::kLandmark:
      out << (planar ? "EDGE_SE2_XY " : "EDGE_SE3_TRACKXYZ ") << e.from << ' ' << e.to;
      if (!planar) out << ' ' << e.offset;
      break;
    case EdgeKind::kOdometry:
    case EdgeKind::kLoopClosure:
      out << (planar ? "EDGE_SE2 " : "EDGE_SE3:QUAT ") << e.from << ' ' << e.to;
      break;
  }
  const int n = graph.ResidualSize(e);
  WriteNumbers(out, e.z.data(), e.IsLandmark() ? n : graph.ParameterSize());
  WriteUpperTriangle(out, e.information, n);
  out << '\n';
}

}  // namespace

void WriteG2o(const PoseGraph& graph, std::ostream& out) {
  bool write_prior_offset = false;
  const int64_t prior_id = PriorOffsetId(graph, &write_prior_offset);
  WriteOffsets(graph, out, prior_id, write_prior_offset);
  VerbatimWriter kept(graph, out);
  size_t vertex_index = 0, edge_index = 0;
  for (const Vertex& v : graph.vertices()) {
    kept.Before(vertex_index++, 0);
    WriteVertex(graph, v, out);
  }
  kept.Before(VerbatimWriter::kAll, 0);
  for (const Vertex& v : graph.vertices())
    if (v.fixed) out << "FIX " << v.id << '\n';
  for (const Edge& e : graph.edges()) {
    kept.Before(VerbatimWriter::kAll, edge_index++);
    WriteEdge(graph, e, prior_id, out);
  }
  kept.Rest();
}

std::string ToroRefusal(const PoseGraph& graph) {
  if (graph.HasLandmarks())
    return "TORO has no landmarks (" + std::to_string(graph.CountLandmarks()) +
           " here): write it as g2o";
  if (graph.CountEdges(EdgeKind::kPrior) != 0)
    return "TORO has no prior edges (" + std::to_string(graph.CountEdges(EdgeKind::kPrior)) +
           " here): write it as g2o";
  if (!graph.verbatim_lines().empty())
    return "TORO has no place for the " + std::to_string(graph.verbatim_lines().size()) +
           " lines kept verbatim: write it as g2o";
  return {};
}

namespace {

// The inverse of ToroInformation2D: (xx, xy, yy, tt, xt, yt).
void WriteToroInformation2D(std::ostream& out, const Matrix6d& m) {
  const double v[6] = {m(0, 0), m(0, 1), m(1, 1), m(2, 2), m(0, 2), m(1, 2)};
  WriteNumbers(out, v, 6);
}

// TORO's roll-pitch-yaw weights from g2o's (the inverse of the reader's
// Omega_q = J^T Omega_rpy J, J = diag(I, 2I)).
Matrix6d ToroInformation3D(const Matrix6d& info_q) {
  Vector6d j;
  j << 1, 1, 1, 0.5, 0.5, 0.5;
  return j.asDiagonal() * info_q * j.asDiagonal();
}

void WriteToroPose(std::ostream& out, const PoseGraph& graph, const PoseParams& p) {
  if (graph.dimension() == 2) {
    WriteNumbers(out, p.data(), 3);
  } else {
    const Vector6d v = ToSE3(p).ToEulerVector();
    WriteNumbers(out, v.data(), 6);
  }
}

}  // namespace

void WriteToro(const PoseGraph& graph, std::ostream& out) {
  const std::string refusal = ToroRefusal(graph);
  if (!refusal.empty()) throw std::invalid_argument(refusal);
  const bool planar = graph.dimension() == 2;
  for (const Vertex& v : graph.vertices()) {
    out << (planar ? "VERTEX2 " : "VERTEX3 ") << v.id;
    WriteToroPose(out, graph, v.x);
    out << '\n';
  }
  for (const Vertex& v : graph.vertices())
    if (v.fixed) out << "FIX " << v.id << '\n';
  for (const Edge& e : graph.edges()) {
    out << (planar ? "EDGE2 " : "EDGE3 ") << e.from << ' ' << e.to;
    WriteToroPose(out, graph, e.z);
    if (planar) {
      WriteToroInformation2D(out, e.information);
    } else {
      WriteUpperTriangle(out, ToroInformation3D(e.information), 6);
    }
    out << '\n';
  }
}

std::optional<GraphFormat> GraphFormatOf(const std::string& path) {
  auto ends_with = [&](const std::string& suffix) {
    if (path.size() < suffix.size()) return false;
    for (size_t k = 0; k < suffix.size(); ++k)
      if (std::tolower(static_cast<unsigned char>(path[path.size() - suffix.size() + k])) != suffix[k])
        return false;
    return true;
  };
  if (ends_with(".g2o")) return GraphFormat::kG2o;
  if (ends_with(".graph")) return GraphFormat::kToro;
  return std::nullopt;
}

void WriteGraph(const PoseGraph& graph, GraphFormat format, std::ostream& out) {
  if (format == GraphFormat::kToro) {
    WriteToro(graph, out);
  } else {
    WriteG2o(graph, out);
  }
}

void WriteG2o(const PoseGraph& graph, const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) { WriteG2o(graph, out); });
}

}  // namespace cairn
