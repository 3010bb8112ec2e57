#include "cairn/frontend/svg.h"

#include <algorithm>
#include <sstream>

namespace cairn::frontend {

std::string TrajectorySvg(const std::vector<PlotPath>& paths) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : paths)
    for (const SE2& s : p.poses) {
      x0 = std::min(x0, s.x());
      x1 = std::max(x1, s.x());
      y0 = std::min(y0, s.y());
      y1 = std::max(y1, s.y());
    }
  if (x0 > x1) x0 = y0 = 0, x1 = y1 = 1;
  const double span = std::max({x1 - x0, y1 - y0, 1e-3});
  const double size = 800, pad = 20, scale = (size - 2 * pad) / span;
  const double w = (x1 - x0) * scale + 2 * pad, h = (y1 - y0) * scale + 2 * pad + 20 * paths.size();
  std::ostringstream os;
  os.precision(6);
  os << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h
     << "\" viewBox=\"0 0 " << w << ' ' << h << "\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (size_t k = 0; k < paths.size(); ++k) {
    os << "<polyline fill=\"none\" stroke=\"" << paths[k].colour << "\" stroke-width=\"1.5\" points=\"";
    for (const SE2& s : paths[k].poses)
      os << pad + (s.x() - x0) * scale << ',' << pad + (y1 - s.y()) * scale << ' ';
    os << "\"/>\n<text x=\"" << pad << "\" y=\"" << h - 20 * (paths.size() - k) + 14
       << "\" font-family=\"sans-serif\" font-size=\"14\" fill=\"" << paths[k].colour << "\">"
       << paths[k].label << "</text>\n";
  }
  os << "</svg>\n";
  return os.str();
}

}  // namespace cairn::frontend
