// The one mapping from MaterialMaps onto the shading functions: forward evaluation of any
// texel of any model. The synthetic renderer, the fit metrics and the CPU preview call this.
#pragma once

#include <cstdint>

#include "core/material_maps.h"
#include "core/vec3.h"

namespace matfit {

// Value of texel `index` (row-major) in channel c for unit light l and view v, per unit light
// intensity, without cast shadows. Lambert/Blinn–Phong/Cook–Torrance: ρ_d,c (n·l)⁺ + lobe;
// Heinrich: t_c a_c + t_c (n_raw·l) [+ L_spec,c (n_s·h)^e]; PTM: Σ_j a_{c,j} B_j(l).
float EvaluateTexel(const MaterialMaps& m, int64_t index, int c, const Vec3f& l, const Vec3f& v);

}  // namespace matfit
