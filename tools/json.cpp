#include "tools/json.h"

#include <cmath>
#include <set>

namespace cairn::tools {
namespace {

const char* NonFiniteName(double v) { return std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf"; }

std::string Note(const std::set<std::string>& names) {
  std::string note = "not finite (";
  for (const std::string& n : names) note += (note.back() == '(' ? "" : ", ") + n;
  return note + ")";
}

Json Number(double v, std::set<std::string>* non_finite) {
  if (std::isfinite(v)) return v;
  non_finite->insert(NonFiniteName(v));
  return nullptr;
}

}  // namespace

void PutNumber(Json& object, const std::string& key, double v) {
  std::set<std::string> non_finite;
  object[key] = Number(v, &non_finite);
  if (!non_finite.empty()) object[key + "_note"] = Note(non_finite);
}

void PutMatrix(Json& object, const std::string& key, const Eigen::MatrixXd& m) {
  std::set<std::string> non_finite;
  Json rows = Json::array();
  for (int r = 0; r < m.rows(); ++r) {
    if (m.cols() == 1) {
      rows.push_back(Number(m(r, 0), &non_finite));
      continue;
    }
    Json row = Json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(Number(m(r, c), &non_finite));
    rows.push_back(std::move(row));
  }
  object[key] = std::move(rows);
  if (!non_finite.empty()) object[key + "_note"] = Note(non_finite);
}

std::string DumpJson(const Json& json, bool one_line) {
  return json.dump(one_line ? -1 : 2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace cairn::tools
