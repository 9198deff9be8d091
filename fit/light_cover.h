// Whether a light set can support a model (issue 19): a model with nearly as many light-dependent
// coefficients as lights, or a relighting basis the lights barely determine, fits the samples
// closely and predicts other light directions badly — hsh3 on the 12-light psm sets: held-out
// RMSE 9× lambert's (gray 0.209 vs 0.023), basis condition number 2427. The fit warns
// (overfit-risk) and `--model auto` does not consider such a model.
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"

namespace matfit::fit {

class FitMethod;

inline constexpr double kMinLightsPerCoefficient = 2;  // lit lights per light parameter
inline constexpr double kMaxBasisCondition = 1000;     // σ_max / σ_min of the relighting basis

// Empty when `lights` support `method`; else why not, naming the counts and the fix.
std::string LightCoverShortfall(const std::vector<LightSample>& lights, const FitMethod& method);

}  // namespace matfit::fit
