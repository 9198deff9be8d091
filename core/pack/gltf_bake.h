// glTF stand-ins for fits a glTF material cannot carry (compute only).
#pragma once

#include "core/image.h"
#include "core/material_maps.h"

namespace matfit {

// The least-squares Lambertian surface of a fit's own prediction, for relighting bases (ptm,
// hsh, rbf) whose light dependence no glTF material has: over K = 37 directions on the cap
// θ ≤ 60° (front lighting), the luminance gives b = argmin Σ_k (Y(l_k) − b·l_k)², the normal
// n = b / |b| (flipped into z ≥ 0; (0,0,1) where |b| vanishes); then per channel
// ρ_c = Σ_k R_c(l_k) max(0, n·l_k) / Σ_k max(0, n·l_k)², clamped to [0, 1]. *base gets ρ (3
// planes), *normal the unit normal (3 planes). The model's batched evaluator does the work.
void LambertianBake(const MaterialMaps& m, Image* base, Image* normal);

}  // namespace matfit
