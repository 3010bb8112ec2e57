#include "cairn/graph/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <utility>

namespace cairn {
namespace {

constexpr double kPanel = 520;   // panel width and height, px
constexpr double kMargin = 20;   // inside a panel, around the drawing
constexpr double kTitle = 28;    // band above the panels for titles

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

struct Mapping {
  double x0 = 0, y0 = 0, scale = 1, ox = 0, oy = 0;
  // SVG's y axis points down; the map's up.
  void Apply(const PoseParams& p, double* sx, double* sy) const {
    *sx = ox + (p[0] - x0) * scale;
    *sy = oy - (p[1] - y0) * scale;
  }
};

// Grows [min, max] on both axes by one point, when finite.
void Extend(double x, double y, double* xmin, double* xmax, double* ymin, double* ymax) {
  if (!std::isfinite(x) || !std::isfinite(y)) return;
  *xmin = std::min(*xmin, x);
  *xmax = std::max(*xmax, x);
  *ymin = std::min(*ymin, y);
  *ymax = std::max(*ymax, y);
}

// One scale for everything the panel draws: its graph and its trajectories.
Mapping Fit(const PlotPanel& p, double left, double top) {
  double xmin = std::numeric_limits<double>::infinity(), ymin = xmin;
  double xmax = -xmin, ymax = -xmin;
  if (p.graph)
    for (const Vertex& v : p.graph->vertices()) Extend(v.x[0], v.x[1], &xmin, &xmax, &ymin, &ymax);
  for (const PlotTrajectory& t : p.trajectories)
    for (const SE2& s : t.poses) Extend(s.x(), s.y(), &xmin, &xmax, &ymin, &ymax);
  Mapping m;
  if (!(xmin <= xmax)) return m;  // no finite point
  const double span = std::max({xmax - xmin, ymax - ymin, 1e-9});
  const double inner = kPanel - 2 * kMargin;
  m.scale = inner / span;
  // Centre the drawing in its panel, equal scale on both axes.
  m.x0 = 0.5 * (xmin + xmax);
  m.y0 = 0.5 * (ymin + ymax);
  m.ox = left + kPanel / 2;
  m.oy = top + kPanel / 2;
  return m;
}

void Path(std::ostream& out, const PoseGraph& g, const Mapping& m, bool loops,
          const std::string& color, double width, double opacity) {
  std::string d;
  char buf[64];
  for (const Edge& e : g.edges()) {
    if (!e.JoinsPoses() || (e.kind == EdgeKind::kLoopClosure) != loops) continue;
    double ax, ay, bx, by;
    m.Apply(g.vertex(e.from).x, &ax, &ay);
    m.Apply(g.vertex(e.to).x, &bx, &by);
    if (!std::isfinite(ax + ay + bx + by)) continue;
    std::snprintf(buf, sizeof buf, "M%.1f %.1fL%.1f %.1f", ax, ay, bx, by);
    d += buf;
  }
  if (d.empty()) return;
  out << "<path fill=\"none\" stroke=\"" << color << "\" stroke-width=\"" << width
      << "\" stroke-opacity=\"" << opacity << "\" stroke-linecap=\"round\" d=\"" << d
      << "\"/>\n";
}

// Landmarks as small dots in the graph's colour.
void Landmarks(std::ostream& out, const PoseGraph& g, const Mapping& m, const std::string& color) {
  if (!g.HasLandmarks()) return;
  out << "<g fill=\"" << color << "\" fill-opacity=\"0.8\">\n";
  char buf[96];
  for (const Vertex& v : g.vertices()) {
    if (!v.landmark) continue;
    double x, y;
    m.Apply(v.x, &x, &y);
    if (!std::isfinite(x + y)) continue;
    std::snprintf(buf, sizeof buf, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2\"/>\n", x, y);
    out << buf;
  }
  out << "</g>\n";
}

// Each trajectory as one polyline (non-finite poses left out), then their
// labels in their colours, one line each, in the panel's lower-left corner.
void Trajectories(std::ostream& out, const PlotPanel& p, const Mapping& m, double left,
                  double top) {
  char buf[64];
  for (const PlotTrajectory& t : p.trajectories) {
    std::string points;
    for (const SE2& s : t.poses) {
      double x, y;
      m.Apply({s.x(), s.y()}, &x, &y);
      if (!std::isfinite(x + y)) continue;
      std::snprintf(buf, sizeof buf, "%s%.1f,%.1f", points.empty() ? "" : " ", x, y);
      points += buf;
    }
    if (points.empty()) continue;
    out << "<polyline fill=\"none\" stroke=\"" << t.color
        << "\" stroke-width=\"1.5\" stroke-linejoin=\"round\" points=\"" << points << "\"/>\n";
  }
  const size_t n = p.trajectories.size();
  for (size_t k = 0; k < n; ++k)
    out << "<text x=\"" << left + kMargin << "\" y=\"" << top + kPanel - kMargin - 18.0 * (n - 1 - k)
        << "\" font-family=\"sans-serif\" font-size=\"14\" fill=\"" << p.trajectories[k].color
        << "\">" << Escape(p.trajectories[k].label) << "</text>\n";
}

}  // namespace

PlotPanel TrajectoryPanel(std::vector<PlotTrajectory> trajectories, std::string title) {
  PlotPanel p;
  p.title = std::move(title);
  p.trajectories = std::move(trajectories);
  return p;
}

void WriteSvgPlot(std::ostream& out, const std::vector<PlotPanel>& panels,
                  const std::string& title) {
  const double width = std::max<size_t>(panels.size(), 1) * kPanel;
  const double top = title.empty() ? kTitle : 2 * kTitle;
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\""
      << top + kPanel << "\" viewBox=\"0 0 " << width << " " << top + kPanel << "\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<g font-family=\"sans-serif\" font-size=\"14\" text-anchor=\"middle\">\n";
  if (!title.empty())
    out << "<text x=\"" << width / 2 << "\" y=\"" << kTitle - 8 << "\" font-size=\"16\">"
        << Escape(title) << "</text>\n";
  for (size_t i = 0; i < panels.size(); ++i)
    out << "<text x=\"" << (i + 0.5) * kPanel << "\" y=\"" << top - 8 << "\">"
        << Escape(panels[i].title) << "</text>\n";
  out << "</g>\n";
  for (size_t i = 0; i < panels.size(); ++i) {
    const PlotPanel& p = panels[i];
    if (!p.graph && p.trajectories.empty()) continue;
    const double left = i * kPanel;
    out << "<rect x=\"" << left + 2 << "\" y=\"" << top + 2 << "\" width=\"" << kPanel - 4
        << "\" height=\"" << kPanel - 4 << "\" fill=\"none\" stroke=\"#ccc\"/>\n";
    const Mapping m = Fit(p, left, top);
    if (p.graph) {
      // Loop closures first, underneath the trajectory.
      if (p.loop_closures) Path(out, *p.graph, m, true, p.loop_color, 0.5, 0.35);
      Path(out, *p.graph, m, false, p.color, 1.0, 0.9);
      Landmarks(out, *p.graph, m, p.color);
    }
    Trajectories(out, p, m, left, top);
  }
  out << "</svg>\n";
}

}  // namespace cairn
