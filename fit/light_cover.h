// Whether a light set can support a model (issue 19): a model with nearly as many light-dependent
// coefficients as lights, or a relighting basis the lights barely determine, fits the samples
// closely and predicts other light directions badly — hsh3 on the 12-light psm sets: held-out
// RMSE 9× lambert's (gray 0.209 vs 0.023), basis condition number 2427. Nor can lights at one
// elevation check a specular lobe at any other: a noise-free Blinn–Phong ring (plastic-ring12)
// is recovered exactly, but on the real leaf sheet's 45° ring the lobe models' leave-one-out
// errors were 2.9–1600× lambert's and 2–4.5 % of texels exceeded their bounds. The fit warns
// (overfit-risk), claims no error bound, and `--model auto` does not consider the model.
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"

namespace matfit::fit {

class FitMethod;

inline constexpr double kMinLightsPerCoefficient = 2;  // lit lights per light parameter
inline constexpr double kMaxBasisCondition = 1000;     // σ_max / σ_min of the relighting basis
// Lobe models need lit lights spread over at least this many degrees of elevation (the dataset's
// elevation-span warning uses the same span).
inline constexpr double kMinLobeElevationSpanDeg = 5;

// θl range (degrees) of the lights above the surface plane; span() < 0 when none is lit.
struct ElevationRange {
  double lo = 90, hi = 0;
  double span() const { return hi - lo; }
};
ElevationRange LitElevationRange(const std::vector<LightSample>& lights);

// Empty when `lights` support `method`; else why not, naming the counts and the fix.
std::string LightCoverShortfall(const std::vector<LightSample>& lights, const FitMethod& method);

}  // namespace matfit::fit
