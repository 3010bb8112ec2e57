#include "cairn/graph/pose_difference.h"

#include <cmath>
#include <stdexcept>

namespace cairn {

PoseDifference ComparePoses(const PoseGraph& a, const PoseGraph& b) {
  if (a.dimension() != b.dimension())
    throw std::invalid_argument("comparing a 2D graph with a 3D one");
  PoseDifference d;
  const size_t n = a.vertices().size();
  size_t poses = 0;
  for (const Vertex& va : a.vertices()) {
    const PoseParams& xb = b.vertex(va.id).x;
    if (va.landmark) {
      // A point: its position only.
      double t2 = 0;
      for (int k = 0; k < a.dimension(); ++k) t2 += (va.x[k] - xb[k]) * (va.x[k] - xb[k]);
      d.max_translation = std::max(d.max_translation, std::sqrt(t2));
      d.rms_translation += t2;
      continue;
    }
    ++poses;
    double t, r;
    if (a.dimension() == 2) {
      const SE2 pa = ToSE2(va.x), pb = ToSE2(xb);
      t = (pa.translation() - pb.translation()).norm();
      r = std::abs(pa.Between(pb).theta());
    } else {
      const SE3 pa = ToSE3(va.x), pb = ToSE3(xb);
      t = (pa.translation() - pb.translation()).norm();
      r = QuaternionLog(pa.rotation().conjugate() * pb.rotation()).norm();
    }
    r *= 180.0 / M_PI;
    d.max_translation = std::max(d.max_translation, t);
    d.max_rotation_deg = std::max(d.max_rotation_deg, r);
    d.rms_translation += t * t;
    d.rms_rotation_deg += r * r;
  }
  if (n > 0) d.rms_translation = std::sqrt(d.rms_translation / n);
  if (poses > 0) d.rms_rotation_deg = std::sqrt(d.rms_rotation_deg / poses);
  return d;
}

}  // namespace cairn
