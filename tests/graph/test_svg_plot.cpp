// The hand-written SVG plots: well-formed enough for a browser, one panel
// per graph, loop closures apart from the trajectory, 3D as its x-y view,
// labelled trajectories (the front-end's) in one frame with a legend.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <sstream>

#include "cairn/graph/svg_plot.h"

namespace cairn {
namespace {

PoseGraph Square(int dimension) {
  PoseGraph g(dimension);
  const double xy[4][2] = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  for (int i = 0; i < 4; ++i) {
    PoseParams p{};
    p[0] = xy[i][0];
    p[1] = xy[i][1];
    if (dimension == 3) {
      p[2] = 100.0 * i;  // height: must not show in the x-y view
      p[6] = 1;          // unit quaternion
    }
    g.AddVertex(i, p);
  }
  for (int i = 0; i < 4; ++i) {
    Edge e;
    e.from = i;
    e.to = (i + 1) % 4;
    e.kind = KindForBetween(e.from, e.to);
    if (dimension == 3) e.z[6] = 1;
    g.AddEdge(e);
  }
  return g;
}

std::string Plot(const std::vector<PlotPanel>& panels, const std::string& title) {
  std::ostringstream os;
  WriteSvgPlot(os, panels, title);
  return os.str();
}

size_t Count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

TEST(SvgPlot, PanelsTitlesAndEdgeClasses) {
  const PoseGraph g = Square(2);
  PlotPanel before{&g, "before <start>", "#888888"};
  PlotPanel after{&g, "after"};
  const std::string svg = Plot({before, after}, "a & b");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("width=\"1040\""), std::string::npos);  // two panels side by side
  EXPECT_NE(svg.find("before &lt;start&gt;"), std::string::npos);
  EXPECT_NE(svg.find("a &amp; b"), std::string::npos);
  // Per panel: one path of loop closures (one segment: 3 -> 0), one of odometry.
  EXPECT_EQ(Count(svg, "stroke=\"#d62728\""), 2u);
  EXPECT_EQ(Count(svg, "stroke=\"#888888\""), 1u);
  EXPECT_EQ(Count(svg, "stroke=\"#1f5fbf\""), 1u);
  EXPECT_EQ(Count(svg, "<path"), 4u);
}

TEST(SvgPlot, ThreeDimensionalGraphsAreDrawnFromAbove) {
  const PoseGraph g2 = Square(2), g3 = Square(3);
  PlotPanel a{&g2, "t"}, b{&g3, "t"};
  // Same x-y, different heights: the same drawing.
  EXPECT_EQ(Plot({a}, ""), Plot({b}, ""));
}

TEST(SvgPlot, EqualScaleOnBothAxesAndNoNonFiniteCoordinates) {
  PoseGraph g = Square(2);
  g.vertex(2).x[0] = std::nan("");
  PlotPanel p{&g, "t"};
  const std::string svg = Plot({p}, "");
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  // The 10 m square maps to equal spans in x and y.
  const PoseGraph sq = Square(2);
  PlotPanel q{&sq, "t"};
  const std::string s2 = Plot({q}, "");
  std::smatch m;
  std::vector<double> xs, ys;
  std::string rest = s2;
  const std::regex point("[ML]([-0-9.]+) ([-0-9.]+)");
  while (std::regex_search(rest, m, point)) {
    xs.push_back(std::stod(m[1]));
    ys.push_back(std::stod(m[2]));
    rest = m.suffix();
  }
  ASSERT_FALSE(xs.empty());
  const double wx = *std::max_element(xs.begin(), xs.end()) - *std::min_element(xs.begin(), xs.end());
  const double wy = *std::max_element(ys.begin(), ys.end()) - *std::min_element(ys.begin(), ys.end());
  EXPECT_NEAR(wx, wy, 0.2);
  EXPECT_GT(wx, 100);
}

// The points of every polyline, as (x, y) pairs.
std::vector<std::pair<double, double>> PolylinePoints(const std::string& svg) {
  std::vector<std::pair<double, double>> out;
  const std::regex line("points=\"([^\"]*)\""), pair("([-0-9.]+),([-0-9.]+)");
  for (std::sregex_iterator it(svg.begin(), svg.end(), line), end; it != end; ++it) {
    const std::string pts = (*it)[1];
    for (std::sregex_iterator p(pts.begin(), pts.end(), pair); p != end; ++p)
      out.emplace_back(std::stod((*p)[1]), std::stod((*p)[2]));
  }
  return out;
}

TEST(SvgPlot, TrajectoriesShareOnePanelWithALegend) {
  // Dead reckoning drifting away from the optimised path: both in one frame.
  PlotTrajectory dr{"dead <reckoning>", "#d62728", {}}, opt{"optimised", "#1f77b4", {}};
  for (int i = 0; i <= 10; ++i) {
    dr.poses.emplace_back(i, 0.5 * i, 0);
    opt.poses.emplace_back(i, 0, 0);
  }
  opt.poses.emplace_back(std::nan(""), 0, 0);  // left out, not drawn as nan
  const std::string svg = Plot({TrajectoryPanel({dr, opt})}, "");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("width=\"520\""), std::string::npos);  // one panel
  EXPECT_EQ(Count(svg, "<polyline"), 2u);
  EXPECT_EQ(Count(svg, "<path"), 0u);  // no graph in this panel
  EXPECT_NE(svg.find(">dead &lt;reckoning&gt;</text>"), std::string::npos);
  EXPECT_NE(svg.find("fill=\"#1f77b4\">optimised</text>"), std::string::npos);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  const auto pts = PolylinePoints(svg);
  ASSERT_EQ(pts.size(), 22u);
  // One scale: the 10 m run spans the inner panel, the 5 m rise half that,
  // and both lines start at the same point.
  EXPECT_EQ(pts[0], pts[11]);
  EXPECT_NEAR(pts[10].first - pts[0].first, 480, 0.2);
  EXPECT_NEAR(pts[0].second - pts[10].second, 240, 0.2);  // y up
  for (const auto& [x, y] : pts) {
    EXPECT_GE(x, 0);
    EXPECT_LE(x, 520);
  }
}

TEST(SvgPlot, TrajectoriesOverAGraphWidenItsFrame) {
  const PoseGraph g = Square(2);
  PlotPanel p{&g, "t"};
  const std::string alone = Plot({p}, "");
  p.trajectories.push_back({"far", "#000000", {SE2(0, 0, 0), SE2(20, 0, 0)}});
  const std::string both = Plot({p}, "");
  EXPECT_EQ(Count(both, "<path"), Count(alone, "<path"));
  EXPECT_EQ(Count(both, "<polyline"), 1u);
  EXPECT_NE(alone, both);  // the square is drawn at half the scale now
}

}  // namespace
}  // namespace cairn
