// Seed method A, specular step (METHODS.md §2), shared by the fast and reference fits:
// L_spec = residual of sample #1 (θl = θv) after the diffuse reconstruction, then one exponent
// per material minimising the total deviation over e ∈ [exponent_min, exponent_max].
#pragma once

#include "core/light_stack.h"
#include "fit/fit_types.h"

namespace matfit::fit {

// Writes one fitted texel: mean texture t (C values), ambient per channel (C values), the
// unnormalised normal n_raw (stored as unit normal + |n|). C = 1 fills all three planes.
void StoreHeinrichTexel(MaterialMaps* maps, int64_t p, int channels, const double t[3],
                        const double ambient[3], const Vec3& n_raw);

// Σ over valid texels, images, channels of (p − p*)² for the maps as they are (p* from
// EvaluateTexel), and the sample count. Used by the exponent search and the tests.
double HeinrichSquaredError(const LightStack& stack, const FitResult& result, int64_t* samples);

// Fills specular_color, exponent, parameters["exponent"]; no-op with a warning when the stack
// has no sample along the view direction.
void AddHeinrichSpecular(const LightStack& stack, const FitOptions& options, FitResult* result);

}  // namespace matfit::fit
