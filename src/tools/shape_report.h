// The shape tables of evaluate's suite mode (eval/shape_evaluation.h): per object kind in
// the markdown table and the JSON summary, per found object in each scene's JSON.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "novelty_detection/eval/shape_evaluation.h"

namespace novelty_detection {
namespace cli {

/// The fitted shapes per object kind beside the floor the data allow, as a markdown table
/// (and a line on people when there are any).
std::string shapeKindMarkdown(const std::vector<KindShapeError>& kinds);

/// The same per kind for the suite's JSON summary ("shapes_by_kind").
nlohmann::json shapeKindJson(const std::vector<KindShapeError>& kinds);

/// One found object's shape figures (a scene's "shapes" in the suite's JSON); a figure that
/// does not apply (the semi-axis error of a composite or of a fit with several parts) is null.
nlohmann::json shapeObjectJson(const ObjectShapeError& e);

}  // namespace cli
}  // namespace novelty_detection
