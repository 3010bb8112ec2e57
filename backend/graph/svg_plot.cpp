#include "cairn/graph/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>

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

Mapping Fit(const PoseGraph& g, double left, double top) {
  double xmin = std::numeric_limits<double>::infinity(), ymin = xmin;
  double xmax = -xmin, ymax = -xmin;
  for (const Vertex& v : g.vertices()) {
    if (!std::isfinite(v.x[0]) || !std::isfinite(v.x[1])) continue;
    xmin = std::min(xmin, v.x[0]);
    xmax = std::max(xmax, v.x[0]);
    ymin = std::min(ymin, v.x[1]);
    ymax = std::max(ymax, v.x[1]);
  }
  Mapping m;
  if (!(xmin <= xmax)) return m;  // no finite vertex
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
    if (e.IsPrior() || (e.kind == EdgeKind::kLoopClosure) != loops) continue;
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

}  // namespace

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
    if (!p.graph) continue;
    const double left = i * kPanel;
    out << "<rect x=\"" << left + 2 << "\" y=\"" << top + 2 << "\" width=\"" << kPanel - 4
        << "\" height=\"" << kPanel - 4 << "\" fill=\"none\" stroke=\"#ccc\"/>\n";
    const Mapping m = Fit(*p.graph, left, top);
    // Loop closures first, underneath the trajectory.
    if (p.loop_closures) Path(out, *p.graph, m, true, p.loop_color, 0.5, 0.35);
    Path(out, *p.graph, m, false, p.color, 1.0, 0.9);
  }
  out << "</svg>\n";
}

}  // namespace cairn
