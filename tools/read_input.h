// How every sub-command reads a pose graph: the global options applied
// (--keep-unknown, --repair-information) and what the repair changed said on
// stderr and put in the reports.
#pragma once

#include <istream>
#include <string>

#include "cairn/graph/graph_io.h"
#include "tools/json.h"

namespace cairn::tools {

ReadOptions InputReadOptions();
// ReadGraph with InputReadOptions, then SayRepairs.
PoseGraph ReadInputGraph(const std::string& path);
PoseGraph ReadInputGraph(std::istream& in, const std::string& name);
// One stderr line when matrices were repaired, nothing otherwise.
void SayRepairs(const std::string& name, const PoseGraph& graph);
// "repaired_information" and "repaired_information_largest_clipped" (the
// most negative eigenvalue clipped, relative to its matrix's largest).
void PutRepairs(Json& object, const PoseGraph& graph);

}  // namespace cairn::tools
