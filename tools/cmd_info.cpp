// cairn info: what a pose-graph file holds and its chi-squared.
#include <cstdio>
#include <iostream>

#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/graph/initialization.h"
#include "tools/args.h"
#include "tools/read_input.h"
#include "tools/command.h"
#include "tools/json.h"

namespace cairn::tools {
namespace {

int RunInfo(int argc, char** argv) {
  std::string path;
  bool json = false, strict = false;
  ArgParser args("info FILE [--json]",
                 "Reads a g2o or TORO pose graph and prints its vertices (poses and point\n"
                 "landmarks), odometry edges, loop closures, priors, landmark observations\n"
                 "and priors, fixed vertices, connected components (poses that see a\n"
                 "common landmark are one) and the\n"
                 "chi-squared of the estimate in the file (g2o's definition: the sum of\n"
                 "e^T Omega e over the edges). A file without vertices gets them from its\n"
                 "edges along a spanning tree, and its chi-squared is of that estimate.\n"
                 "A tag cairn does not know is an error naming its line (--keep-unknown\n"
                 "accepts it).");
  args.Positional("FILE", &path, "a .g2o or TORO .graph file");
  args.Flag("json", &json, "print one JSON object (keys vertices, poses, landmarks, odometry_edges, "
                           "loop_closures, priors, landmark_edges, landmark_priors, fixed, "
                           "components, chi2, dimension, repaired_information)");
  args.Flag("strict", &strict, "accepted for old scripts: unknown tags are always refused now "
                               "(unless --keep-unknown)");
  int code = 0;
  if (!args.Parse(argc, argv, &code)) return code;

  const PoseGraph graph = ReadInputGraph(path);
  const size_t components = ConnectedComponents(graph).size();
  const double chi2 = Chi2(graph);
  if (json) {
    Json j;
    j["file"] = path;
    j["dimension"] = graph.dimension();
    j["vertices"] = graph.vertices().size();
    j["poses"] = graph.vertices().size() - graph.CountLandmarks();
    j["landmarks"] = graph.CountLandmarks();
    j["odometry_edges"] = graph.CountEdges(EdgeKind::kOdometry);
    j["loop_closures"] = graph.CountEdges(EdgeKind::kLoopClosure);
    j["priors"] = graph.CountEdges(EdgeKind::kPrior);
    j["landmark_edges"] = graph.CountEdges(EdgeKind::kLandmark);
    j["landmark_priors"] = graph.CountEdges(EdgeKind::kLandmarkPrior);
    j["fixed"] = graph.CountFixed();
    j["components"] = components;
    PutNumber(j, "chi2", chi2);
    PutRepairs(j, graph);
    std::fputs(DumpJson(j, /*one_line=*/true).c_str(), stdout);
    return 0;
  }
  std::printf("file            %s\n", path.c_str());
  std::printf("dimension       %dD (%s)\n", graph.dimension(), graph.dimension() == 2 ? "SE2" : "SE3");
  std::printf("vertices        %zu\n", graph.vertices().size());
  std::printf("poses           %zu\n", graph.vertices().size() - graph.CountLandmarks());
  std::printf("landmarks       %zu\n", graph.CountLandmarks());
  std::printf("odometry edges  %zu\n", graph.CountEdges(EdgeKind::kOdometry));
  std::printf("loop closures   %zu\n", graph.CountEdges(EdgeKind::kLoopClosure));
  std::printf("priors          %zu\n", graph.CountEdges(EdgeKind::kPrior));
  std::printf("landmark edges  %zu\n", graph.CountEdges(EdgeKind::kLandmark));
  std::printf("landmark priors %zu\n", graph.CountEdges(EdgeKind::kLandmarkPrior));
  std::printf("fixed vertices  %zu\n", graph.CountFixed());
  std::printf("components      %zu\n", components);
  std::printf("chi2            %.10g\n", chi2);
  if (graph.information_repairs().matrices > 0)
    std::printf("repaired info   %zu (largest clipped eigenvalue %.3g of its matrix's largest)\n",
                graph.information_repairs().matrices,
                graph.information_repairs().largest_clipped);
  return 0;
}

}  // namespace

CAIRN_COMMAND("info", "counts and chi-squared of a pose-graph file", RunInfo);

}  // namespace cairn::tools
