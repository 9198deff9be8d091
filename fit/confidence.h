// Per-texel confidence: every fit reports a bound on its own relighting error, so that a
// method that fails says so (issue #8's "silent failure" is an error above this bound).
//
// For texel x with n_x usable samples (images × channels; finite, unclipped, divided by the
// light's intensity) and P fitted parameters, the residual variance is
//   s_x² = Σ r² / (n_x − P),   r = p − f(x, l_i)   (f: the shared forward evaluation).
// Noise is pooled over all texels, σ̂² = Σ_x Σ r² / Σ_x (n_x − P), and floors s_x² (one texel's
// few residual degrees of freedom can be small by chance). The error at a new light direction
// l* grows with the design's leverage l*ᵀ(Σ_i l_i l_iᵀ)⁻¹l*; its mean over the supported cone,
// g, against the well-spread value 3/m, gives the extrapolation factor a = max(1, m·g/3). The
// cone is centred on the lights' mean direction (the axis; +z for a dome); its half-angle θ_s
// starts at min(75°, widest light angle from the axis + 15°) and shrinks in 5° steps until
// a ≤ max_extrapolation (2): the bound claims only directions the lights can predict. Where
// a > 1 no residual can tell how a wrong model extrapolates, so up to (a − 1) times the texel's
// mean level μ_x is added. The bound on the RMS error over the supported dome is
//   b_x = sqrt(κ² · max(s_x², σ̂², i_x²) · a · (1 + P/n_x) + ((a − 1) μ_x)²),
// i_x = maps.interpolation_error (an interpolating model's error between its samples, which its
// residuals at the samples do not show; rbf only, else 0).
// Texels with n_x ≤ P, with fewer usable lights than the model's light parameters + 3 (too few
// spare lights to reveal misfit), lights whose moment matrix is singular or that predict no
// dome down to 10° within max_extrapolation, or lights that all miss the frontal cone (no light
// within max_frontal_gap_deg of the sample's +z axis, checked once per stack: the appearance
// under the most common light is never seen, e.g. grazing-only rigs) are kTexelUnverifiable.
// Samples at the file's maximum code count only when the stack may be clipped (integer files),
// and then only where the prediction undershoots them (fit/score.h): a clipped sample records
// that the value reached the clip, not how far above it the appearance went. So on such a stack
// the bound is on the error within the recorded range — prediction and truth each taken up to
// the clip level per unit light and channel, Confidence::recorded_limit (a light brighter than
// the weakest recorded less than that in its own direction: the check is conservative there);
// above it a saturated texel's
// appearance (a highlight's peak) is the model's extrapolation, which no sample can check.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "core/vec3.h"

namespace matfit::fit {

struct ConfidenceOptions {
  double kappa = 3.5;          // coverage factor κ, > 0
  double max_condition = 1e6;  // light moment matrix condition number above which → unverifiable
  double max_frontal_gap_deg = 45;  // some light must have θ ≤ this
  double max_extrapolation = 2;     // largest extrapolation factor a a bound may carry

  bool Check(std::string* why) const;
};

// Size of the model being checked (FitMethod::parameters_per_texel / light_parameters).
struct ModelSize {
  int parameters = 0;   // fitted scalars per texel, counted for RGB
  int per_channel = 0;  // of which fitted per colour channel (grey: P = parameters − 2 · this)
  int light_parameters = 0;  // that the light variation must determine
};

struct Confidence {
  std::vector<float> bound;  // b_x per texel (linear radiance per unit light); +inf when flagged
  double pooled_sigma = 0;   // σ̂
  double extrapolation = 1;  // a
  double supported_theta_deg = 75;  // θ_s: the bound covers light directions within this angle
  Vec3 supported_axis{0, 0, 1};     // of this axis (the lights' mean direction)
  bool frontal_covered = true;      // some light within max_frontal_gap_deg of the normal
  int64_t unverifiable = 0;         // texels newly marked kTexelUnverifiable
  // Per channel (r, g, b), the bound covers values up to this (linear radiance per unit light:
  // the maximum code over the weakest light's intensity in that channel); +inf when the stack
  // cannot be clipped (float files, no sample at the maximum code).
  Vec3 recorded_limit = Vec3(1, 1, 1) * std::numeric_limits<double>::infinity();
  int64_t saturated = 0;  // texels with a bound and a clipped sample (their peak is extrapolated)
};

// status: the fit's status plane (may be empty = all ok); texels found unverifiable are marked
// kTexelUnverifiable in it. Batched over runs of texels; `progress` gets runs done / total.
struct TexelResiduals;  // fit/score.h

// `residuals`, when given, are ScoreStack's sums for this stack, maps and status (a fused pass
// that also scored the reconstruction); otherwise the pass runs here, reporting `progress`.
Confidence ComputeConfidence(const LightStack& stack, const MaterialMaps& maps, ModelSize size,
                             std::vector<uint8_t>* status, const ConfidenceOptions& options = {},
                             const ProgressFn& progress = {},
                             const TexelResiduals* residuals = nullptr);

// How tight the bound is: the ratio b_x / e_x of each texel's bound to an actual error of the
// same texel (its held-out RMS, or its relighting error against truth), over texels whose status
// is ok with a finite bound and a finite e_x > 0.
struct BoundRatio {
  double median = NAN, p90 = NAN;
  int64_t texels = 0;
  double exceeded_fraction = NAN;  // share of those texels whose error exceeds the bound
};
BoundRatio BoundToActualRatio(const std::vector<float>& bound, const std::vector<float>& actual,
                              const std::vector<uint8_t>& status);

// The lights' mean direction (upper hemisphere; +z when there is none).
Vec3 LightAxis(const std::vector<LightSample>& lights);
// The starting θ_s: min(75°, widest light angle from `axis` + 15°).
double SupportedThetaDeg(const std::vector<LightSample>& lights, const Vec3& axis);

// `count` directions on a Fibonacci spiral, equal-area within max_theta_deg of `axis`.
std::vector<Vec3> DomeDirections(int count, double max_theta_deg, const Vec3& axis = {0, 0, 1});

// Mean leverage over `count` DomeDirections within max_theta_deg of axis:
// g = mean l*ᵀ M⁻¹ l*, M = Σ_i l_i l_iᵀ over the lights; +inf when M's condition number exceeds
// max_condition.
double MeanDomeLeverage(const std::vector<LightSample>& lights, double max_condition,
                        double max_theta_deg = 75, const Vec3& axis = {0, 0, 1}, int count = 64);

}  // namespace matfit::fit
