// A sub-command's files, checked before any work: an OutputSet (outputs
// distinct from each other and from the inputs, directories there and
// writable) that also refuses an output whose format cairn fixes (a g2o
// graph, an SVG plot, a PNG image) under a name of another kind.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"

namespace cairn::tools {

class CommandOutputs : public OutputSet {
 public:
  // Empty paths (an option not given) are not declared.
  void Input(const std::string& path);
  // With an `extension` (".g2o", ".svg", ".png"), the name must end in it,
  // in any case; an existing device or FIFO (/dev/stdout, a pipe) takes any
  // name, since its name says nothing of it.
  void Output(const std::string& path, const char* extension = nullptr);
  // A pose graph: *.g2o, or *.graph for TORO (a device or FIFO gets g2o).
  void GraphOutput(const std::string& path);
  // Throws std::runtime_error naming the output when `graph` cannot be
  // written in a declared graph output's format (TORO and priors, say):
  // called once the input is read, before it is solved.
  void CheckGraphFits(const PoseGraph& graph) const;
  // Writes `graph` to a declared output in the format its name says.
  void WriteGraph(const std::string& path, const PoseGraph& graph);
  // OutputSet::Check, then the extensions; std::runtime_error naming the
  // path(s) at fault.
  void Check();

 private:
  std::vector<std::pair<std::string, std::string>> extensions_;
  std::vector<std::string> graphs_;
};

}  // namespace cairn::tools
