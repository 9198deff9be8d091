// Fitting under near (point) lights: the stack is cut into tiles small enough that one distant
// light per tile — the light seen from the tile's centre, with its 1/r² fall-off — stays within
// a tolerance of every texel's own (core/near_lights.h), each tile is fitted with the distant-
// light method, and the tiles' maps are put back together.
#pragma once

#include <functional>
#include <string>

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_types.h"

namespace matfit::fit {

using FitFn = std::function<StatusOr<FitResult>(const LightStack&, const FitOptions&)>;

// `fit` over the tiles of a stack whose lights have positions, in parallel; the result's
// parameters gain near_tile_texels, near_tiles, near_max_direction_error_deg,
// near_max_falloff_error and near_nearest_light_px (the plan's measured figures). Model-wide
// parameters are the tiles' texel-weighted mean (condition numbers: the largest); the lobe
// models' shared shape is estimated once over all tiles (two passes). `method` names the fit in
// errors. Refuses rbf (its light basis table is one per fit) and heinrich (its specular
// reference is the light along the view, which a near lamp is only at the image centre).
StatusOr<FitResult> FitNearLights(const std::string& method, const FitFn& fit,
                                  const LightStack& stack, const FitOptions& options);

}  // namespace matfit::fit
