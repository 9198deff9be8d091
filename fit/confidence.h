// Per-texel confidence: every fit reports a bound on its own relighting error, so that a
// method that fails says so (issue #8's "silent failure" is an error above this bound).
//
// For texel x with n_x usable samples (images × channels; finite, unclipped, divided by the
// light's intensity) and P fitted parameters, the residual variance is
//   s_x² = Σ r² / (n_x − P),   r = p − f(x, l_i)   (f: the shared forward evaluation).
// Noise is pooled over all texels, σ̂² = Σ_x Σ r² / Σ_x (n_x − P), and floors s_x² (one texel's
// few residual degrees of freedom can be small by chance). The error at a new light direction
// l* grows with the design's leverage l*ᵀ(Σ_i l_i l_iᵀ)⁻¹l*; its mean over a dome of directions
// θ ≤ 75°, g, against the well-spread value 3/m, gives the extrapolation factor
// a = max(1, m·g/3). The bound on the RMS error over directions is
//   b_x = κ · sqrt(max(s_x², σ̂²) · a · (1 + P/n_x)).
// Texels with n_x ≤ P, or lights whose moment matrix is singular, are kTexelUnverifiable.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"

namespace matfit::fit {

struct ConfidenceOptions {
  double kappa = 3.5;          // coverage factor κ, > 0
  double max_condition = 1e6;  // light moment matrix condition number above which → unverifiable

  bool Check(std::string* why) const;
};

struct Confidence {
  std::vector<float> bound;  // b_x per texel (linear radiance per unit light); +inf when flagged
  double pooled_sigma = 0;   // σ̂
  double extrapolation = 1;  // a
  int64_t unverifiable = 0;  // texels newly marked kTexelUnverifiable
};

// status: the fit's status plane (may be empty = all ok); texels found unverifiable are marked
// kTexelUnverifiable in it. parameters: P of the method (FitMethod::parameters_per_texel()).
Confidence ComputeConfidence(const LightStack& stack, const MaterialMaps& maps, int parameters,
                             std::vector<uint8_t>* status, const ConfidenceOptions& options = {});

// Mean leverage over a Fibonacci dome of `count` directions at θ ≤ 75°: g = mean l*ᵀ M⁻¹ l*,
// M = Σ_i l_i l_iᵀ over the stack's lights; +inf when M's condition number exceeds max_condition.
double MeanDomeLeverage(const std::vector<LightSample>& lights, double max_condition,
                        int count = 64);

}  // namespace matfit::fit
