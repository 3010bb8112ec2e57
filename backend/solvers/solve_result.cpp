#include "cairn/solvers/solve_result.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace cairn {

namespace {

using Json = nlohmann::ordered_json;

// JSON has no infinity or NaN: null, and a note beside it saying which
// (docs/api.md, "JSON output").
void PutNumber(Json& object, const std::string& key, double v) {
  if (std::isfinite(v)) {
    object[key] = v;
    return;
  }
  object[key] = nullptr;
  object[key + "_note"] = std::string("not finite (") +
                          (std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf") + ")";
}

// A context value: an integer or a finite number when the whole text is
// one, else the text.
Json ContextValue(const std::string& s) {
  if (s.empty() || s.find_first_of("xXnN") != std::string::npos) return s;
  char* end = nullptr;
  errno = 0;
  const long long i = std::strtoll(s.c_str(), &end, 10);
  if (*end == '\0' && errno == 0) return i;
  const double v = std::strtod(s.c_str(), &end);
  if (*end == '\0' && std::isfinite(v)) return v;
  return s;
}

}  // namespace

SolverKind ParseSolverKind(const std::string& text) {
  if (text == "ceres") return SolverKind::kCeres;
  if (text == "gn") return SolverKind::kGaussNewton;
  throw std::invalid_argument("unknown solver '" + text + "' (expected ceres or gn)");
}

const char* ToString(SolverKind kind) { return kind == SolverKind::kCeres ? "ceres" : "gn"; }

RobustLoss ParseRobustLoss(const std::string& text) {
  if (text.empty()) return {};
  const size_t colon = text.find(':');
  // Kernel names as users type them: Huber, CAUCHY, DCS.
  std::string name = text.substr(0, colon);
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  RobustLoss loss;
  if (name == "none" && colon == std::string::npos) return loss;
  if (name == "huber") {
    loss.kind = RobustLoss::kHuber;
  } else if (name == "cauchy") {
    loss.kind = RobustLoss::kCauchy;
  } else if (name == "dcs") {
    loss.kind = RobustLoss::kDcs;
  } else {
    throw std::invalid_argument("unknown robust loss '" + text +
                                "' (expected none, huber:DELTA, cauchy:DELTA or dcs:PHI)");
  }
  if (colon == std::string::npos)
    throw std::invalid_argument("robust loss '" + text + "' needs a width: " + name + ":DELTA");
  const std::string value = text.substr(colon + 1);
  char* end = nullptr;
  loss.delta = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || !std::isfinite(loss.delta) || loss.delta <= 0)
    throw std::invalid_argument("robust loss '" + text + "': DELTA must be a positive number");
  return loss;
}

std::string ToString(const RobustLoss& loss) {
  char buf[64];
  switch (loss.kind) {
    case RobustLoss::kNone: return "none";
    case RobustLoss::kHuber: std::snprintf(buf, sizeof buf, "huber:%g", loss.delta); break;
    case RobustLoss::kCauchy: std::snprintf(buf, sizeof buf, "cauchy:%g", loss.delta); break;
    case RobustLoss::kDcs: std::snprintf(buf, sizeof buf, "dcs:%g", loss.delta); break;
  }
  return buf;
}

void WriteReportJson(const SolveResult& r, std::ostream& out,
                     const std::vector<std::pair<std::string, std::string>>& context) {
  Json j = Json::object();
  for (const auto& [key, value] : context) j[key] = ContextValue(value);
  j["solver"] = r.solver;
  j["linear_solver"] = r.linear_solver;
  PutNumber(j, "initial_chi2", r.initial_chi2);
  PutNumber(j, "final_chi2", r.final_chi2);
  j["iterations"] = r.iterations;
  PutNumber(j, "time_s", r.time_s);
  PutNumber(j, "setup_time_s", r.setup_time_s);
  PutNumber(j, "linearize_time_s", r.linearize_time_s);
  PutNumber(j, "linear_solver_time_s", r.linear_solver_time_s);
  j["termination"] = r.termination;
  j["message"] = r.message;
  j["converged"] = r.converged;
  j["usable"] = r.usable;
  Json trace = Json::array();
  for (const IterationRecord& t : r.trace) {
    Json it = Json::object();
    it["iteration"] = t.iteration;
    PutNumber(it, "chi2", t.chi2);
    PutNumber(it, "step_norm", t.step_norm);
    PutNumber(it, "time_s", t.time_s);
    it["accepted"] = t.accepted;
    PutNumber(it, "linear_solver_time_s", t.linear_solver_time_s);
    trace.push_back(std::move(it));
  }
  j["trace"] = std::move(trace);
  // Text that is not UTF-8 (a file name in another encoding) is written
  // with replacement characters rather than refused.
  out << j.dump(2, ' ', false, Json::error_handler_t::replace) << "\n";
}

bool IsUsableEstimate(double initial_objective, double final_objective) {
  return std::isfinite(final_objective) && final_objective <= initial_objective;
}

std::string FormatIteration(const IterationRecord& t) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "iter %3d  chi2 %.9e  |step| %.3e  %s  %8.3f s", t.iteration,
                t.chi2, t.step_norm, t.accepted ? "accepted" : "refused ", t.time_s);
  return buf;
}

}  // namespace cairn
