// The methods of the ladder as plain functions (method.cc wraps them in FitMethod).
#pragma once

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_types.h"

namespace matfit::fit {

// mean: t_c = mean_i p_ci / I_ci.
StatusOr<FitResult> FitMean(const LightStack& stack, const FitOptions& options);

// lambert (METHODS.md §3): g = (LᵀL)⁻¹Lᵀ y on luminance y, n = g/|g|, then per channel the
// least-squares ρ_c = Σ_i p_ci (n·l_i) / Σ_i (n·l_i)². One pseudo-inverse for all texels and
// one pass over the planes.
StatusOr<FitResult> FitLambert(const LightStack& stack, const FitOptions& options);

// lambert-robust (METHODS.md §3): rank trimming then reweighting rejects shadowed and
// highlight samples per texel; ≥ 3 well-conditioned inliers or the texel is flagged.
StatusOr<FitResult> FitLambertRobust(const LightStack& stack, const FitOptions& options);

// blinn-phong / cook-torrance (METHODS.md §4): per-texel Levenberg–Marquardt on normal,
// diffuse albedo and the lobe's two parameters (k_s, e) or (F0, roughness), from lambert-robust.
StatusOr<FitResult> FitBlinnPhong(const LightStack& stack, const FitOptions& options);
StatusOr<FitResult> FitCookTorrance(const LightStack& stack, const FitOptions& options);

// svbrdf (issue 17): the Cook–Torrance SVBRDF (normal, albedo, F0 and GGX roughness per texel;
// Smith masking, Schlick Fresnel) fitted jointly over every view × light of a multi-view stack
// (each sample with its own view), started from cook-torrance on the most frontal view. On a
// single-view stack it is cook-torrance with a per-texel roughness. Maps as cook-torrance.
StatusOr<FitResult> FitSvbrdf(const LightStack& stack, const FitOptions& options);
// Its two steps (a streamed fit runs the second band by band, fit/stream_fit.h): the start,
// cook-torrance on the most frontal view alone (a single-view stack); then the joint refinement
// over the images of `stack`, whose row 0 is row `row0` of the start's maps. Per texel, so a
// band's texels come out as the whole stack's.
StatusOr<FitResult> SvbrdfStart(const LightStack& frontal_view, const FitOptions& options);
StatusOr<FitResult> RefineSvbrdf(const LightStack& stack, const FitResult& start, int row0,
                                 const FitOptions& options);

// lafortune (METHODS.md §4): 1 or 2 isotropic lobes (C_z = 1; amplitude, C_xy and exponent per
// lobe), same two-stage per-texel LM with one lobe shape per material by default.
StatusOr<FitResult> FitLafortune(const LightStack& stack, const FitOptions& options, int lobes);
// The lobe models' (blinn-phong, cook-torrance, lafortune1, lafortune2) material-wide shape in
// fitting coordinates from per-texel-lobe maps of the stack (FitOptions::per_texel_lobe), the
// estimator the fits use: per shape parameter, the median over ok texels whose first amplitude
// is above a tenth of its 90th percentile. NotFound when no texel shows a lobe; InvalidArgument
// for another method.
StatusOr<std::vector<double>> SharedLobeShape(const std::string& method, const LightStack& stack,
                                              const MaterialMaps& maps,
                                              const std::vector<uint8_t>& status);
// Whether `method` is one of those (its shape is one per material unless per_texel_lobe).
bool HasSharedLobeShape(const std::string& method);

// ptm (METHODS.md §4): 6 polynomial coefficients per channel in (u, v) = (l_x, l_y), one
// pseudo-inverse for all texels. Coefficients in maps.coefficients (plane c·6 + j).
// srgb (ptm-srgb): fitted to the samples' sRGB encode, as RTI tools fit the stored 8-bit codes;
// evaluated as decode(clamp(Σ a B, 0, 1)) (MaterialMaps::basis_srgb).
StatusOr<FitResult> FitPtm(const LightStack& stack, const FitOptions& options, bool srgb = false);

// hsh (METHODS.md §4): hemispherical harmonics with `order` bands (order² coefficients per
// channel; the ladder has orders 2 and 3), one pseudo-inverse for all texels.
StatusOr<FitResult> FitHsh(const LightStack& stack, const FitOptions& options, int order,
                           bool srgb = false);

// rbf (fit/rbf_fit.cc): kRbfComponents PCA components (at most N − 3 and N / 2 for N lights) of the
// samples over the lights, each interpolated over light directions by Gaussian RBFs (width and
// regularisation by leave-one-light-out), tabulated on a kRbfTableSize² grid
// (MaterialMaps::basis_table), and per-texel coefficients fitted against that table like ptm/hsh.
// srgb as for FitPtm.
inline constexpr int kRbfComponents = 9, kRbfTableSize = 64;
StatusOr<FitResult> FitRbf(const LightStack& stack, const FitOptions& options, bool srgb = false);

// σ_max / σ_min of the N × k basis matrix of the method's relighting basis over `lights`
// ("ptm", "hsh1" … "hsh4", each also with "-srgb"; +inf when rank-deficient); 0 for a method
// without such a basis.
double RelightBasisCondition(const std::vector<LightSample>& lights, std::string method);

// heinrich (METHODS.md §2), fast: exploits the shared structure of the 6 × 6 normal equations
// (closed form: a_c = 1 − m·n, n = (Σ_i (l_i − m)(l_i − m)ᵀ)⁻¹ (Σ_c t_c q_c / Σ_c t_c² − Σ_i l_i),
// q_c = Σ_i p_ci l_i), then the seed specular map and the exponent search.
StatusOr<FitResult> FitHeinrich(const LightStack& stack, const FitOptions& options);

// heinrich reference: the literal per-texel 6-unknown normal equations AᵀA x = Aᵀb inverted
// by Gauss–Jordan, as the seed does. Fills normal (unit), normal_scale, ambient, albedo (t).
StatusOr<FitResult> FitHeinrichReference(const LightStack& stack, const FitOptions& options);

// Literal per-texel references of lambert, ptm and hsh (normal equations + Gauss–Jordan per
// texel and channel; fit/linear_reference.cc): same outputs as the fast forms up to float
// rounding, for tests and benchmarks.
StatusOr<FitResult> FitLambertReference(const LightStack& stack, const FitOptions& options);
StatusOr<FitResult> FitPtmReference(const LightStack& stack, const FitOptions& options);
StatusOr<FitResult> FitHshReference(const LightStack& stack, const FitOptions& options, int order);

}  // namespace matfit::fit
