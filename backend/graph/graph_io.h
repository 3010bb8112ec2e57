// Reading and writing pose-graph files: g2o (VERTEX_SE2, EDGE_SE2,
// VERTEX_SE3:QUAT, EDGE_SE3:QUAT, EDGE_PRIOR_SE2, EDGE_SE3_PRIOR,
// EDGE_SE3_XYZPRIOR (a position-only prior), FIX; point
// landmarks: VERTEX_XY, EDGE_SE2_XY, EDGE_PRIOR_XY, VERTEX_TRACKXYZ,
// EDGE_SE3_TRACKXYZ, EDGE_POINTXYZ_PRIOR, PARAMS_SE3OFFSET) and TORO
// (VERTEX2, EDGE2, VERTEX3, EDGE3). Errors name the file and line.
// Every number must be finite, headings and angles within kMaxAbsAngle rad,
// coordinates within kMaxAbsCoordinate (text_input.h).
#pragma once

#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>

#include "cairn/graph/pose_graph.h"
#include "cairn/graph/text_input.h"

namespace cairn {

struct ReadOptions {
  // A line whose tag cairn does not know is an error ("FILE:LINE: unknown
  // tag"), since skipping it would lose what it says. With keep_unknown it
  // is kept verbatim instead (PoseGraph::verbatim_lines) and WriteG2o writes
  // it back in its place.
  bool keep_unknown = false;
  // An indefinite information matrix (some direction of the error with
  // negative weight: chi2 could go below zero) is an error naming its line.
  // With repair_information it is replaced by the nearest positive
  // semi-definite matrix (its negative eigenvalues set to zero), counted in
  // PoseGraph::information_repairs. A singular one is taken either way.
  bool repair_information = false;
  // A longer line is an error, not a buffer without end (text_input.h).
  size_t max_line_bytes = kDefaultMaxLineBytes;
};

// Reads a g2o or TORO file (told apart by their tags). A file with edges but
// no vertices gets its vertices by chaining the measurements along a
// spanning tree from the lowest id (landmarks from their first
// observation). A PARAMS_SE3OFFSET must come before the edges that name it.
// Throws ParseError.
PoseGraph ReadGraph(const std::string& path, const ReadOptions& options = {});
PoseGraph ReadGraph(std::istream& in, const std::string& name, const ReadOptions& options = {});

// Writes g2o with every double in round-trip precision, in g2o's own tags
// (the graph's PARAMS_SE3OFFSET lines first). The file is written beside
// its destination and renamed when complete: never a half file.
void WriteG2o(const PoseGraph& graph, const std::string& path);
void WriteG2o(const PoseGraph& graph, std::ostream& out);

// TORO's form (VERTEX2/EDGE2, VERTEX3/EDGE3 with roll-pitch-yaw and TORO's
// order of the information entries), which ReadGraph reads back to the same
// chi2; fixed vertices as FIX lines, as g2o writes them. TORO has no priors and
// no place for lines kept verbatim: ToroRefusal says why a graph cannot be
// written so, empty when it can, and WriteToro throws std::invalid_argument
// with that reason.
std::string ToroRefusal(const PoseGraph& graph);
void WriteToro(const PoseGraph& graph, std::ostream& out);

enum class GraphFormat { kG2o, kToro };
// By the name's extension, in any case: .g2o, .graph (TORO); none otherwise.
std::optional<GraphFormat> GraphFormatOf(const std::string& path);
void WriteGraph(const PoseGraph& graph, GraphFormat format, std::ostream& out);

}  // namespace cairn
