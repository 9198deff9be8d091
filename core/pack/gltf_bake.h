// glTF stand-ins for fits a glTF material cannot carry (compute only).
#pragma once

#include "core/image.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"

namespace matfit {

// The standard PBR surface closest to a relighting basis (ptm, hsh, rbf), whose light
// dependence no glTF material has: glTF's dielectric as viewers draw it
// (shading::GltfDielectricHalf: Lambert under the Fresnel term + the GGX lobe with
// multiple-scattering compensation), fitted to the model's own prediction y_c(l_k), view
// straight down, over K = 85 directions on the cap θ ≤ 60° (rings every 12°, about 12° apart
// on each ring), each weighted by its irradiance cos θ. Per texel:
//  1. normal: the luminance's least-squares Lambertian, b = argmin Σ_k (Y(l_k) − b·l_k)²,
//     n = b / |b| (flipped into z ≥ 0; (0,0,1) where |b| vanishes);
//  2. lobe: at roughness r the model y_c = ρ'_c d + κ (F0 a + b) (d = (1 − w) max(0, n·l),
//     a = S_r (1 − w), b = S_r w, S_r the lobe at F0 = 1, w = (1 − v·h)^5, ρ' = (1 − F0) ρ,
//     κ = 1 + F0 (1/E(r) − 1)) is linear in (ρ', F0) for κ held: F0 ∈ [0, 0.81] by a few
//     fixed-point steps on κ, ρ ∈ [0, 1] in closed form; r the material's (the median of full
//     searches — a grid of 8, then golden section to ±0.01 — on up to 1024 texels), then the
//     best of r/1.25, r, 1.25 r per texel;
//  3. the normal of the prediction less that lobe, then two Gauss–Newton steps on the normal's
//     slopes (ρ, F0 re-solved at each step), and step 2's choice of r again.
// Where no lobe helps, F0 comes out 0 and the surface is the Lambertian of step 1. Texels
// outside the mask are not fitted (black, facing up, F0 0). Cost: about
// 11 lobe evaluations of the K lights per texel (vectorised over the lights).
struct GltfBake {
  Image base;       // ρ, 3 planes, linear
  Image normal;     // unit normal, 3 planes
  Image f0;         // Fresnel reflectance at normal incidence, 1 plane
  Image roughness;  // GGX perceptual roughness r (α = r²), 1 plane
};
// How the texels are fitted: eight at a time (the default: the per-texel arithmetic across the
// texels) or one at a time; the maps are the same bit for bit.
enum class BakeLanes { kBatched, kOneByOne };
// `progress` (optional, called from worker threads one at a time) counts runs of texels done;
// its return value is ignored (the bake is a part of the pack write, which is not cancelled
// midway).
GltfBake BakeBasisAsGgx(const MaterialMaps& m, const ProgressFn& progress = {},
                        BakeLanes lanes = BakeLanes::kBatched);

// E(r): the directional albedo of the Cook–Torrance lobe at F0 = 1 seen along the normal,
// (1/π) ∫ R_s dω by quadrature, r clamped to [1/64, 1]; the multiple-scattering compensation of
// shading::GltfDielectricHalf is 1 + F0 (1/E − 1).
double GgxAlbedoHeadOn(double roughness);

// The stand-in's F0 given what the diffuse shape leaves of its lobe, with the lobe scaled by
// κ = 1 + c F0 (c = 1/E − 1: ≥ 0 up to quadrature error): the solution in [0, 0.81] of
// F0 = u / κ − v, i.e. the positive root of c F0² + (1 + c v) F0 + (v − u) = 0 cut to 0.81,
// or 0 when u − v ≤ 0 (no lobe). u = Σ_c y_c·a⊥ / (channels a⊥·a⊥), v = b·a⊥ / a⊥·a⊥ (a⊥: the
// lobe's F0 part orthogonal to the diffuse shape, b its rest).
double SelfConsistentF0(double u, double v, double c);

// A per-texel F0 map in glTF terms: KHR_materials_ior carries the material's F0 (the 99th
// percentile over the texels inside `mask` — every texel when the mask is empty or of another
// size — at most 0.81: η = (1 + √F0) / (1 − √F0)) and the sRGB specularColorTexture each
// texel's share of it in [0, 1]. ior 0 when nothing reflects.
struct GltfF0 {
  double ior = 0;
  Image share;  // 1 plane
};
GltfF0 SplitF0ForGltf(const Image& f0, const Image& mask = {});

}  // namespace matfit
