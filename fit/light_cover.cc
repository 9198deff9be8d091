#include "fit/light_cover.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fit/method.h"
#include "fit/methods.h"

namespace matfit::fit {

ElevationRange LitElevationRange(const std::vector<LightSample>& lights) {
  ElevationRange r;
  for (const LightSample& l : lights)
    if (l.direction.z > 0) r.lo = std::min(r.lo, l.theta_deg), r.hi = std::max(r.hi, l.theta_deg);
  return r;
}

std::string LightCoverShortfall(const std::vector<LightSample>& lights, const FitMethod& method) {
  int lit = 0;  // lights above the surface plane: the others add nothing to a texel facing +z
  for (const LightSample& l : lights) lit += l.direction.z > 0 ? 1 : 0;
  const int k = method.light_parameters();
  char why[640];
  if (lit < kMinLightsPerCoefficient * k) {
    std::snprintf(why, sizeof why,
                  "%s fits %d light-dependent coefficients per texel from %d lights (fewer than "
                  "%.0f per coefficient): it can match these images and still predict other "
                  "light directions badly; use a model with at most %d "
                  "such coefficients, or capture more lights",
                  method.name().c_str(), k, lit, kMinLightsPerCoefficient,
                  int(lit / kMinLightsPerCoefficient));
    return why;
  }
  const std::string& name = method.name();
  const bool lobe =
      name == "blinn-phong" || name == "cook-torrance" || name.rfind("lafortune", 0) == 0;
  // rbf interpolates between the lights: under one ring it knows that ring only.
  const bool learned = name.rfind("rbf", 0) == 0;
  if (lobe || learned) {
    const ElevationRange e = LitElevationRange(lights);
    if (lit > 0 && e.span() < kMinLobeElevationSpanDeg) {
      std::snprintf(why, sizeof why,
                    "every light lies at θl %.1f°…%.1f°: no other elevation checks %s's %s, so "
                    "its predictions there are unverified (on a real 45° ring, lobe fits missed "
                    "held-out lights by 3-1600× lambert's error) and no error bound is claimed; "
                    "use lambert, or add lights at other elevations",
                    e.lo, e.hi, name.c_str(),
                    lobe ? "specular lobe" : "interpolation across elevations");
      return why;
    }
  }
  const double condition = RelightBasisCondition(lights, method.name());
  if (!(condition <= kMaxBasisCondition)) {
    std::snprintf(why, sizeof why,
                  "the lights barely determine %s's basis (condition number %.3g > %.0f: they "
                  "cover too little of the hemisphere for its terms); predictions for other "
                  "light directions are unreliable; use a lower-order model or spread the lights",
                  method.name().c_str(), condition, kMaxBasisCondition);
    return why;
  }
  return {};
}

}  // namespace matfit::fit
