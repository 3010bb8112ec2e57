// The hand-written SVG plots: well-formed enough for a browser, one panel
// per graph, loop closures apart from the trajectory, 3D as its x-y view.
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

}  // namespace
}  // namespace cairn
