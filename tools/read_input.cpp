#include "tools/read_input.h"

#include <cstdio>

#include "tools/args.h"

namespace cairn::tools {

ReadOptions InputReadOptions() {
  ReadOptions options;
  options.keep_unknown = Globals().keep_unknown;
  options.repair_information = Globals().repair_information;
  return options;
}

PoseGraph ReadInputGraph(const std::string& path) {
  PoseGraph graph = ReadGraph(path, InputReadOptions());
  SayRepairs(path, graph);
  return graph;
}

PoseGraph ReadInputGraph(std::istream& in, const std::string& name) {
  PoseGraph graph = ReadGraph(in, name, InputReadOptions());
  SayRepairs(name, graph);
  return graph;
}

void SayRepairs(const std::string& name, const PoseGraph& graph) {
  const InformationRepairs& r = graph.information_repairs();
  if (r.matrices == 0) return;
  std::fprintf(stderr,
               "%s: --repair-information: %zu of %zu information matrices were indefinite, "
               "replaced by the nearest positive semi-definite ones (negative eigenvalues set "
               "to zero; the largest clipped was %.3g of its matrix's largest eigenvalue, line "
               "%zu)\n",
               name.c_str(), r.matrices, graph.edges().size(), r.largest_clipped,
               r.largest_line);
}

void PutRepairs(Json& object, const PoseGraph& graph) {
  const InformationRepairs& r = graph.information_repairs();
  object["repaired_information"] = r.matrices;
  PutNumber(object, "repaired_information_largest_clipped", r.largest_clipped);
}

}  // namespace cairn::tools
