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

// Two-sided leaf (maps.translucency present; METHODS.md §5). Frames: z out of the upper side;
// the lower side's frame is the upper one turned 180° about x, (x, −y, −z).
// - light and view above: EvaluateTexel (upper side: diffuse + the model's lobe);
// - light below, view above (back-lit): ρ_t,c Σ h_i ℋ_i(ω) with ω = l in the lower frame, or
//   the diffuse BTDF ρ_t,c max(0, ω_z) without HL2 maps; light above, view below: the same
//   with ω = l in the upper frame;
// - light and view below: Lambert of albedo_back (or albedo) on the lower side's flat normal.
float EvaluateLeafTexel(const MaterialMaps& m, int64_t index, int c, const Vec3f& l,
                        const Vec3f& v);

}  // namespace matfit
