// cairn corrupt: add wrong loop closures to a pose graph (random ones, or
// aliased groups that agree with each other), to measure how a solver copes.
#include <cmath>
#include <cstdio>
#include <ostream>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/robust/corrupt.h"
#include "tools/args.h"
#include "tools/read_input.h"
#include "tools/command.h"
#include "tools/outputs.h"

namespace cairn::tools {
namespace {

int RunCorrupt(int argc, char** argv) {
  std::string in, out, list, truth;
  int outliers = -1, seed = 1, grouped = 0;
  double fraction = -1;
  ArgParser args(
      "corrupt IN -o OUT.g2o (--outliers N | --fraction F) [--grouped SIZE [--truth T.g2o]] "
      "[--seed S] [--list FILE]",
      "Adds wrong loop closures to a g2o or TORO pose graph: random pairs of\n"
      "non-consecutive vertices not yet joined, random measurements (translation\n"
      "within the largest loop closure's, rotation uniform) and the information of\n"
      "the file's median loop closure. With --grouped SIZE they come in groups of\n"
      "SIZE that agree with each other and with the odometry (perceptual aliasing:\n"
      "closure k of a group measures x_{a+k}^-1 T x_{b+k}, one rigid T per group, on\n"
      "the file's poses or --truth's). Writes the graph as g2o and the pairs it\n"
      "added, one 'FROM TO' a line, to OUT.g2o.outliers.txt (or --list).");
  args.Positional("IN", &in, "a .g2o or TORO .graph file");
  args.Option("output", &out, "OUT.g2o", "where to write the corrupted graph (g2o; TORO if *.graph)");
  args.Alias("-o", "output");
  args.Option("outliers", &outliers, "N", "how many wrong loop closures to add");
  args.Option("fraction", &fraction, "F",
              "as many wrong loop closures as F times the file's loop closures (rounded)");
  args.Option("grouped", &grouped, "SIZE",
              "aliased groups of SIZE loop closures (the last holds the remainder) instead "
              "of random ones");
  args.Option("truth", &truth, "T.g2o",
              "with --grouped: measure the groups on these poses (same ids) instead of the "
              "file's, e.g. cairn simulate's --truth");
  args.Option("seed", &seed, "S", "seed of the random choices");
  args.Option("list", &list, "FILE", "where to write the added pairs");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;
  if (out.empty()) {
    PrintError("corrupt needs an output file (-o OUT.g2o)");
    return 2;
  }
  if ((outliers < 0) == (fraction < 0)) {
    PrintError("give exactly one of --outliers N (N >= 0) and --fraction F (F >= 0)");
    return 2;
  }
  if (grouped < 0 || (grouped == 0 && !truth.empty())) {
    PrintError("--grouped takes a size of at least 1, and --truth needs --grouped");
    return 2;
  }
  if (list.empty()) list = out + ".outliers.txt";
  // The graph and its list go in place together, and only once both are written.
  CommandOutputs outputs;
  outputs.Input(in);
  outputs.Input(truth);
  outputs.GraphOutput(out);
  outputs.Output(list);
  outputs.Check();
  PoseGraph graph = ReadInputGraph(in);
  outputs.CheckGraphFits(graph);
  if (fraction >= 0)
    outliers = static_cast<int>(
        std::lround(fraction * static_cast<double>(graph.CountEdges(EdgeKind::kLoopClosure))));
  const PoseGraph poses = truth.empty() ? PoseGraph(graph.dimension()) : ReadInputGraph(truth);
  if (!truth.empty() && poses.dimension() != graph.dimension()) {
    PrintError(truth + ": a " + std::to_string(poses.dimension()) + "D graph for a " +
               std::to_string(graph.dimension()) + "D input");
    return 1;
  }
  std::vector<VertexPair> added;
  try {
    added = grouped > 0 ? AddAliasedLoopClosures(graph, outliers, grouped,
                                                 static_cast<uint64_t>(seed),
                                                 truth.empty() ? nullptr : &poses)
                        : AddWrongLoopClosures(graph, outliers, static_cast<uint64_t>(seed));
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return 1;
  }
  outputs.WriteGraph(out, graph);
  outputs.Write(list, [&](std::ostream& os) {
    os << "# wrong loop closures added to " << in << " (seed " << seed;
    if (grouped > 0) os << ", aliased groups of " << grouped;
    os << "): FROM TO\n";
    for (const auto& [a, b] : added) os << a << " " << b << "\n";
  });
  outputs.Commit();
  std::fprintf(stderr, "%s: added %zu wrong loop closures -> %s (list: %s)\n", in.c_str(),
               added.size(), out.c_str(), list.c_str());
  return 0;
}

}  // namespace

CAIRN_COMMAND("corrupt", "add wrong loop closures (random or aliased groups) to a pose graph",
              RunCorrupt);

}  // namespace cairn::tools
