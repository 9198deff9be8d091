// What every fitting method takes and returns.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/progress.h"
#include "core/vec3.h"

namespace matfit::fit {

// Per-texel outcome, one byte per texel (an SoA plane): failures are visible as a map.
enum TexelStatus : uint8_t {
  kTexelOk = 0,
  kTexelMasked = 1,          // outside the dataset mask: not fitted
  kTexelNoSignal = 2,        // (near) black in every image: nothing to fit
  kTexelNonFinite = 3,       // NaN/Inf among its samples
  kTexelTooFewLights = 4,    // fewer than 3 usable (lit, unclipped) samples
  kTexelIllConditioned = 5,  // usable lights nearly coplanar for this texel
  kTexelSaturated = 6,       // a sample sits at the file's maximum code (clipped): the linear
                             // models cannot use it (lambert-robust drops such samples instead)
  kTexelUnverifiable = 7,    // the fit cannot bound its own error: no residual degrees of freedom,
                             // or the lights cannot predict other directions (fit/confidence.h)
  kTexelSuspectData = 8,     // a stack-level defect was detected (e.g. gamma-encoded images read
                             // as linear, fit/diagnostics.h): the maps are not trustworthy
};
const char* TexelStatusName(uint8_t status);

struct FitOptions {
  int tile = 64;  // work unit ≈ tile² texels (as full-width row strips), [8, 4096]
  // heinrich: use n_s = (0,0,1) inside the specular term (METHODS.md §2 improved variant).
  bool heinrich_flat_specular_normal = false;
  // heinrich: fit the specular map and exponent (else the diffuse + ambient part only).
  bool heinrich_specular = true;
  // blinn-phong / cook-torrance: fit the lobe shape (e, roughness) per texel instead of once
  // per material.
  bool per_texel_lobe = false;
  // blinn-phong / cook-torrance / lafortune: the material's lobe shape, given (fitting
  // coordinates, SharedLobeShape in fit/methods.h) instead of estimated from this stack; empty:
  // estimate it. Near-light fits (fit/near_fit.h) estimate it once over every tile.
  std::vector<double> lobe_shape;
  // blinn-phong / cook-torrance / lafortune with a material-wide shape estimated from the stack:
  // the per-texel fits whose median is the shape run on a regular grid of N to 2.25N of the texels
  // (N this value; every texel when there are fewer than 4N), 0: on every texel. Stage 2 fits
  // every texel either way (fit/specular_fit.cc).
  int64_t lobe_shape_texels = 16384;
  // Nonlinear fits: Cauchy loss scale σ on residuals (linear units of the normalised samples;
  // 0 = plain least squares). Residual cast shadows and interreflections weigh less: on the
  // psm cat, held-out RMSE 0.0280 → 0.0270 (blinn-phong) at σ = 0.05 (docs/benchmarks.md).
  double robust_scale = 0.05;
  double exponent_min = 1, exponent_max = 1024;  // heinrich exponent search range, 1 ≤ min < max
  // Near lights (light_positions.txt): the largest angle between a texel's light direction
  // and the one its tile is fitted with (fit/near_fit.h), degrees, (0, 10].
  double near_tolerance_deg = 0.25;
  ProgressFn progress;  // tiles done / total; returning false cancels

  bool Check(std::string* why) const;
};

// One view's fit of a per-view model (per-view:<model>, fit/per_view_fit.h).
struct ViewFit {
  double theta_deg = 0, phi_deg = 0;  // the view, as the reader gave it
  Vec3 view{0, 0, 1};                 // unit, toward the camera, tangent frame
  MaterialMaps maps;
  std::vector<uint8_t> status;
  std::map<std::string, double> parameters;  // the view's model-wide values (e.g. its exponent)
};

struct FitResult {
  MaterialMaps maps;
  std::vector<uint8_t> status;  // TexelStatus per texel (row-major)
  std::string method;
  double fit_seconds = 0;
  int64_t flagged_texels = 0;                // status not ok and not masked
  std::map<std::string, double> parameters;  // model-wide values (e.g. "exponent")
  // Texels fitted again from their valid samples after their clipped or non-finite ones were
  // dropped (fit/valid_refit.h): lights dropped per texel (empty when no texel was refitted),
  // texels that got a fit that way, and the samples (lights) dropped in total.
  std::vector<uint16_t> dropped_lights;
  int64_t refit_texels = 0, dropped_samples = 0;
  std::vector<std::string> warnings;
  // per-view:<model>: every view's maps, in the stack's view order; maps and status above are
  // the most frontal view's (views[frontal_view]'s, which render and glTF show). Empty for a
  // model with one set of maps.
  std::vector<ViewFit> views;
  int frontal_view = 0;
};

}  // namespace matfit::fit
