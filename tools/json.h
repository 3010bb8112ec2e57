// The JSON the `cairn` sub-commands write, through one writer
// (nlohmann/json, insertion-ordered), with one rule for numbers JSON cannot
// hold: a non-finite value is written as null and a string "<key>_note"
// follows it ("not finite (inf)"; for a matrix or vector, "not finite (nan)"
// names what its null entries were). Doubles are written so that they read
// back exactly.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

namespace cairn::tools {

using Json = nlohmann::ordered_json;

void PutNumber(Json& object, const std::string& key, double v);
// Rows of numbers ([[...], ...]); a vector (one column) as a flat array.
void PutMatrix(Json& object, const std::string& key, const Eigen::MatrixXd& m);

// Indented by two (one line when `one_line`), with a final newline. Text that
// is not UTF-8 (a file name in another encoding) gets replacement characters
// rather than making the output invalid.
std::string DumpJson(const Json& json, bool one_line = false);

}  // namespace cairn::tools
