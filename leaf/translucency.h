// Leaf translucency precompute (METHODS.md §5): multipole transmittance, self-shadowed
// irradiance and HL2 projection, as the published direct method (reference) and a fast one.
//
//   E(x, ω)      = ρ(x) V(x, ω) max(0, n(x)·ω)                      irradiance below the surface
//   L_t^D(x_o,ω) = A_p Σ_{x_i} T(|x_o − x_i|, d(x_i)) E(x_i, ω)      directional translucency
//   h_i(x)       = (2π/N_L) Σ_m ℋ_i(ω_m) L_t^D(x, ω_m)               HL2 projection
//
// ρ is the transmission weight (luminance of the translucency map), d the thickness (mm), n and
// V in the lit (lower) side's frame. Both implementations also return the response to unit
// irradiance R(x_o) = A_p Σ T(|x_o − x_i|, d(x_i)) ρ(x_i) and h_i / R, the coefficients in the
// renderer's convention (L_t = ρ_t Σ h_i ℋ_i(ω), so a flat unshadowed leaf has h_i = √(2π)/3).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/status.h"
#include "core/vec3.h"
#include "leaf/multipole.h"

namespace matfit::leaf {

struct TransportInput {
  double mm_per_texel = 0;           // texel pitch, mm (A_p = pitch²)
  const Image* rho = nullptr;        // 1 plane, transmission weight ≥ 0
  const Image* thickness = nullptr;  // 1 plane, mm
  const Image* normal = nullptr;     // 3 planes, lit-side frame; null = flat (0, 0, 1)
  const Image* horizon = nullptr;    // horizon angles (leaf/horizon.h); null = no self-shadowing
  const std::vector<uint8_t>* mask = nullptr;  // 1 = leaf; null = every texel
};

struct TranslucencyOptions {
  MultipoleParams multipole;
  int directions = 128;            // N_L
  double kernel_threshold = 1e-6;  // kernel radius: where T falls below this, 1/mm²
  int max_kernel_radius = 128;     // texels; larger kernels are cut (with a warning)
  // Fast method: terms of the kernel's thickness expansion are added until its relative L1
  // error at every thickness sample and midpoint is below this (the precomputed maps differ
  // from the reference by much less: the kernel errors have both signs).
  double kernel_tolerance = 0.01;
  int max_kernel_terms = 16;
  bool Check(std::string* why) const;
};

struct TranslucencyResult {
  Image hl2_raw;              // 3 planes: h_i as defined above
  Image response;             // 1 plane: R(x)
  Image hl2;                  // 3 planes: h_i / R (√(2π)/3 where R = 0)
  std::vector<uint8_t> thin;  // 1 = thickness below the model's validity, clamped
  int64_t thin_texels = 0;
  int kernel_radius = 0;    // texels
  bool kernel_cut = false;  // the radius hit max_kernel_radius
  int kernel_terms = 0;     // fast method: terms of the kernel's thickness expansion
  double kernel_error = 0;  // fast method: their worst relative L1 kernel error
  std::vector<std::string> warnings;
};

// The published method: N_L non-stationary convolutions (one per direction), then projection.
StatusOr<TranslucencyResult> PrecomputeTranslucencyReference(const TransportInput& in,
                                                             const TranslucencyOptions& o);
// Projection first (3 convolutions instead of N_L, exact by linearity), then the
// non-stationary kernel as a short thickness-separable expansion K(r; d) ≈ Σ_q A_q(d) B_q(r)
// (leading singular vectors of the kernel family over the leaf's thickness range), so each
// convolution is Σ_q B_q ∗ (A_q(d)·ε): a few FFT convolutions, whatever the thickness range.
StatusOr<TranslucencyResult> PrecomputeTranslucencyFast(const TransportInput& in,
                                                        const TranslucencyOptions& o);
// L_t^D(·, ω) for one light direction (lit-side frame, ω.z > 0) by the direct sum.
StatusOr<Image> DirectionalTranslucency(const TransportInput& in, const TranslucencyOptions& o,
                                        const Vec3& w);
// The same for several directions at once (the kernel value of each texel pair is evaluated
// once), at the leaf texels listed in `texels` (null: every leaf texel); others stay 0.
StatusOr<std::vector<Image>> DirectionalTranslucency(const TransportInput& in,
                                                     const TranslucencyOptions& o,
                                                     const std::vector<Vec3>& lights,
                                                     const std::vector<int64_t>* texels);

}  // namespace matfit::leaf
