#include "cairn/frontend/trajectory_eval.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

namespace cairn::frontend {

const char* AlignmentName(Alignment a) {
  switch (a) {
    case Alignment::kNone: return "none";
    case Alignment::kRigid: return "se3";
    case Alignment::kSimilarity: return "sim3";
  }
  return "?";
}

bool ParseAlignment(const std::string& text, Alignment* out) {
  for (Alignment a : {Alignment::kNone, Alignment::kRigid, Alignment::kSimilarity})
    if (text == AlignmentName(a)) {
      *out = a;
      return true;
    }
  return false;
}

const char* PairingName(Pairing p) {
  switch (p) {
    case Pairing::kScanIndex: return "scan index";
    case Pairing::kVertexId: return "vertex id";
    case Pairing::kStamp: return "stamp";
  }
  return "?";
}

namespace {

bool KnowsScans(const Trajectory& t) {
  for (long i : t.scan_index)
    if (i < 0) return false;
  return !t.scan_index.empty();
}

// Scan index with scan index, or vertex id with vertex id / rank.
std::vector<std::pair<size_t, size_t>> PairByKey(const Trajectory& est, const Trajectory& ref,
                                                 Pairing pairing) {
  auto key = [pairing](const Trajectory& t, size_t i) -> long {
    if (pairing == Pairing::kScanIndex) return t.scan_index[i];
    return t.stamps_are_ids ? static_cast<long>(std::llround(t.stamps[i])) : static_cast<long>(i);
  };
  std::map<long, size_t> ref_at;
  for (size_t j = 0; j < ref.size(); ++j) ref_at.emplace(key(ref, j), j);
  std::vector<std::pair<size_t, size_t>> pairs;
  for (size_t i = 0; i < est.size(); ++i) {
    auto it = ref_at.find(key(est, i));
    if (it != ref_at.end()) pairs.emplace_back(i, it->second);
  }
  return pairs;
}

// Stamps in whole microseconds: equal keys are "the same stamp" (a log's
// printed times are no finer), and distances between keys are exact.
struct StampGroup {
  long long key;
  std::vector<size_t> members;  // in order of appearance
};

std::vector<StampGroup> GroupByStamp(const Trajectory& t) {
  std::map<long long, std::vector<size_t>> at;
  for (size_t i = 0; i < t.size(); ++i) {
    if (!(std::abs(t.stamps[i]) <= kMaxAbsStamp))
      throw std::runtime_error("stamp " + std::to_string(t.stamps[i]) + " is not a time in seconds");
    at[std::llround(t.stamps[i] * 1e6)].push_back(i);
  }
  std::vector<StampGroup> groups;
  for (auto& [k, m] : at) groups.push_back({k, std::move(m)});
  return groups;
}

// The nearest reference groups within the window on either side of each
// estimate group, closest pairs taken first. Only a few per side are worth
// keeping: a wide --max-dt must not make this quadratic.
std::vector<std::pair<size_t, size_t>> PairByStamp(const Trajectory& est, const Trajectory& ref,
                                                   double max_dt) {
  constexpr int kPerSide = 4;
  const long long window = std::llround(std::min(std::max(max_dt, 0.0), 1e12) * 1e6);
  const std::vector<StampGroup> eg = GroupByStamp(est), rg = GroupByStamp(ref);
  std::vector<std::tuple<long long, size_t, size_t>> candidates;  // |dt|, est group, ref group
  for (size_t g = 0; g < eg.size(); ++g) {
    const long long k = eg[g].key;
    const size_t p = static_cast<size_t>(
        std::lower_bound(rg.begin(), rg.end(), k, [](const StampGroup& r, long long v) { return r.key < v; }) -
        rg.begin());
    for (size_t j = p, n = 0; j < rg.size() && n < kPerSide && rg[j].key - k <= window; ++j, ++n)
      candidates.emplace_back(rg[j].key - k, g, j);
    for (size_t j = p, n = 0; j > 0 && n < kPerSide && k - rg[j - 1].key <= window; --j, ++n)
      candidates.emplace_back(k - rg[j - 1].key, g, j - 1);
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> est_used(eg.size(), false), ref_used(rg.size(), false);
  std::vector<std::pair<size_t, size_t>> pairs;
  for (const auto& [dt, g, j] : candidates) {
    if (est_used[g] || ref_used[j]) continue;
    est_used[g] = ref_used[j] = true;
    // Groups of unequal sizes: which is which cannot be told, both are left out.
    if (eg[g].members.size() != rg[j].members.size()) continue;
    for (size_t m = 0; m < eg[g].members.size(); ++m)
      pairs.emplace_back(eg[g].members[m], rg[j].members[m]);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace

Pairing PairingOf(const Trajectory& est, const Trajectory& ref) {
  if (est.stamps_are_ids || ref.stamps_are_ids) return Pairing::kVertexId;
  if (KnowsScans(est) && KnowsScans(ref)) return Pairing::kScanIndex;
  return Pairing::kStamp;
}

std::vector<std::pair<size_t, size_t>> Associate(const Trajectory& est, const Trajectory& ref,
                                                 double max_dt) {
  const Pairing pairing = PairingOf(est, ref);
  if (pairing == Pairing::kStamp) return PairByStamp(est, ref, max_dt);
  return PairByKey(est, ref, pairing);
}

namespace {

template <int D>
using Vec = Eigen::Matrix<double, D, 1>;
template <int D>
using Mat = Eigen::Matrix<double, D, D>;

template <int D>
struct Similarity {
  Mat<D> R = Mat<D>::Identity();
  Vec<D> t = Vec<D>::Zero();
  double s = 1;
};

// Umeyama's least-squares fit of ref ~ s R est + t (s = 1 unless asked for).
template <int D>
Similarity<D> Align(const std::vector<Vec<D>>& est, const std::vector<Vec<D>>& ref, Alignment how) {
  Similarity<D> a;
  if (how == Alignment::kNone) return a;
  const size_t n = est.size();
  Vec<D> me = Vec<D>::Zero(), mr = Vec<D>::Zero();
  for (size_t k = 0; k < n; ++k) {
    me += est[k];
    mr += ref[k];
  }
  me /= n;
  mr /= n;
  Mat<D> cov = Mat<D>::Zero();
  double var = 0;
  for (size_t k = 0; k < n; ++k) {
    cov += (ref[k] - mr) * (est[k] - me).transpose();
    var += (est[k] - me).squaredNorm();
  }
  Eigen::JacobiSVD<Mat<D>> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat<D> S = Mat<D>::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(D - 1, D - 1) = -1;
  a.R = svd.matrixU() * S * svd.matrixV().transpose();
  if (how == Alignment::kSimilarity) {
    if (!(var > 0)) throw std::runtime_error("sim3 alignment: the estimate's paired positions coincide");
    a.s = (svd.singularValues().asDiagonal() * S).trace() / var;
  }
  a.t = mr - a.s * (a.R * me);
  return a;
}

Eigen::Vector2d Position(const SE2& p) { return p.translation(); }
Eigen::Vector3d Position(const SE3& p) { return p.translation(); }
double Angle(const SE2& p) { return p.theta(); }
double Angle(const SE3& p) {
  const Eigen::Quaterniond& q = p.rotation();
  return 2 * std::atan2(q.vec().norm(), std::abs(q.w()));
}
SE2 Rotation(const Eigen::Matrix2d& R) { return SE2(0, 0, std::atan2(R(1, 0), R(0, 0))); }
SE3 Rotation(const Eigen::Matrix3d& R) { return SE3(Eigen::Quaterniond(R), Eigen::Vector3d::Zero()); }
SE2 ScaleTranslation(const SE2& p, double s) { return s == 1 ? p : SE2(s * p.x(), s * p.y(), p.theta()); }
SE3 ScaleTranslation(const SE3& p, double s) {
  return s == 1 ? p : SE3(p.rotation(), s * p.translation());
}

// The statistics of errors given by their squares (rmse straight from the
// sum of squares), angles in radians turned into degrees.
ErrorStats FromSquares(const std::vector<double>& squares, bool to_degrees = false) {
  auto unit = [to_degrees](double v) { return to_degrees ? v * 180 / M_PI : v; };
  ErrorStats st;
  st.count = squares.size();
  if (squares.empty()) return st;
  std::vector<double> e;
  double sum_sq = 0, sum = 0;
  for (double q : squares) {
    sum_sq += q;
    e.push_back(std::sqrt(q));
    sum += e.back();
  }
  const double n = static_cast<double>(squares.size());
  st.rmse = unit(std::sqrt(sum_sq / n));
  st.mean = unit(sum / n);
  double dev = 0;
  for (double x : e) dev += (x - sum / n) * (x - sum / n);
  st.std = unit(std::sqrt(dev / n));
  std::sort(e.begin(), e.end());
  const size_t m = e.size() / 2;
  st.median = unit(e.size() % 2 ? e[m] : 0.5 * (e[m - 1] + e[m]));
  st.min = unit(e.front());
  st.max = unit(e.back());
  return st;
}

}  // namespace

ErrorStats Summarize(std::vector<double> errors) {
  for (double& e : errors) e *= e;
  return FromSquares(errors);
}

namespace {

template <typename Pose>
void AbsoluteErrors(const std::vector<Pose>& est, const std::vector<Pose>& ref,
                    const std::vector<std::pair<size_t, size_t>>& pairs, Alignment how,
                    TrajectoryErrors* out) {
  constexpr int D = decltype(Position(Pose()))::RowsAtCompileTime;
  std::vector<Vec<D>> pe, pr;
  for (auto [i, j] : pairs) {
    pe.push_back(Position(est[i]));
    pr.push_back(Position(ref[j]));
  }
  const Similarity<D> a = Align<D>(pe, pr, how);
  out->scale = a.s;
  const Pose rotate = Rotation(a.R);
  std::vector<double> trans, rot;
  for (size_t k = 0; k < pairs.size(); ++k) {
    trans.push_back((a.s * (a.R * pe[k]) + a.t - pr[k]).squaredNorm());
    const double angle = Angle(ref[pairs[k].second].Between(rotate * est[pairs[k].first]));
    rot.push_back(angle * angle);
  }
  out->ate = FromSquares(trans);
  out->ate_rot_deg = FromSquares(rot, true);
}

// From each paired pose, the first later one at least `segment` metres
// further along the reference path.
template <typename Pose>
void RelativeErrors(const std::vector<Pose>& est, const std::vector<Pose>& ref,
                    const std::vector<std::pair<size_t, size_t>>& pairs, double segment,
                    TrajectoryErrors* out) {
  std::vector<double> along(pairs.size(), 0);
  for (size_t k = 1; k < pairs.size(); ++k)
    along[k] = along[k - 1] + (Position(ref[pairs[k].second]) - Position(ref[pairs[k - 1].second])).norm();
  std::vector<double> trans, rot;
  size_t b = 0;
  for (size_t a = 0; a < pairs.size(); ++a) {
    if (b < a) b = a;
    while (b < pairs.size() && along[b] - along[a] < segment) ++b;
    if (b >= pairs.size()) break;
    const Pose dr = ref[pairs[a].second].Between(ref[pairs[b].second]);
    const Pose de = ScaleTranslation(est[pairs[a].first].Between(est[pairs[b].first]), out->scale);
    const Pose e = dr.Between(de);
    trans.push_back(Position(e).squaredNorm());
    rot.push_back(Angle(e) * Angle(e));
  }
  out->rpe_trans = FromSquares(trans);
  out->rpe_rot_deg = FromSquares(rot, true);
}

}  // namespace

TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& ref,
                                    const EvalOptions& options) {
  TrajectoryErrors out;
  out.pairing = PairingOf(est, ref);
  const auto pairs = Associate(est, ref, options.max_dt);
  out.matched = pairs.size();
  out.unpaired_est = est.size() - pairs.size();
  out.unpaired_ref = ref.size() - pairs.size();
  out.dimension = std::max(est.dimension, ref.dimension);
  if (pairs.size() < 2) return out;
  if (out.dimension == 2) {
    AbsoluteErrors(est.poses, ref.poses, pairs, options.align, &out);
    RelativeErrors(est.poses, ref.poses, pairs, options.segment, &out);
  } else {
    AbsoluteErrors(est.poses3d, ref.poses3d, pairs, options.align, &out);
    RelativeErrors(est.poses3d, ref.poses3d, pairs, options.segment, &out);
  }
  out.ate_rmse = out.ate.rmse;
  out.rpe_trans_rmse = out.rpe_trans.rmse;
  out.rpe_rot_rmse_deg = out.rpe_rot_deg.rmse;
  out.rpe_pairs = out.rpe_trans.count;
  return out;
}

}  // namespace cairn::frontend
