// Scores of a fit: reconstruction error against the measured stack (METHODS.md §2 deviation)
// and, on synthetic data, errors against the ground-truth maps.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"

namespace matfit::fit {

struct ReconstructionMetrics {
  // dev% = 100 · mean over texels, samples, channels of (p − p*)², values in [0, 1].
  double deviation_percent = 0;
  std::map<int, double> deviation_percent_by_theta;  // θl groups (nearest multiple of 15°)
  double rmse = 0;
  double psnr_db = 0;  // 10 log10(1 / MSE)
  int64_t samples = 0;
  // Only where asked for (the images overload below, i.e. held-out folds): the RMS difference of
  // the 8-bit sRGB codes of sample and prediction (each clamped to [0, 1], encoded, rounded), and
  // PSNR = 10 log10(255² / MSE) over those codes — the figure RTI tools print for 8-bit images.
  double rmse_srgb8 = NAN, psnr_srgb8_db = NAN;
};

// Compares the stack with the maps' forward evaluation at the stack's own lights, over texels
// whose status is 0 (status may be empty: all texels). Batched: each light's constants once,
// runs of kEvalRun texels in parallel, sums in run order (the same for any thread count).
// `progress` is called with texel runs done / total.
ReconstructionMetrics Reconstruction(const LightStack& stack, const MaterialMaps& maps,
                                     const std::vector<uint8_t>& status,
                                     const ProgressFn& progress = {});
// The same over images `images` of the stack only (held-out folds score their test images in
// place instead of copying them), with the 8-bit sRGB figures.
ReconstructionMetrics Reconstruction(const LightStack& stack, const std::vector<int>& images,
                                     const MaterialMaps& maps, const std::vector<uint8_t>& status,
                                     const ProgressFn& progress = {});

// The common texel set (issue 19): every texel of the mask, whatever its status, scored with the
// maps as stored (a flagged texel with its stored value, 0 for the linear models), so that every
// model's figures cover the same texels. CommonTexelStatus keeps kTexelMasked and makes every
// other status ok; AnyFlagged says whether that differs from `status` at all.
std::vector<uint8_t> CommonTexelStatus(const std::vector<uint8_t>& status);
bool AnyFlagged(const std::vector<uint8_t>& status);
// The same over every band of a distributed stack (a collective when `s` is a band: the ranks
// must agree before some of them score the common set and others do not).
bool AnyFlagged(const LightStack& s, const std::vector<uint8_t>& status);

// The figures of Σ (p − p*)² = sse over `samples` samples: rmse, dev% = 100 · MSE, PSNR.
ReconstructionMetrics MetricsFromSums(double sse, double samples);

// Reconstruction figures added up over parts (views, bands of a streamed fit), each part the
// scores of images of one θl group: Σ MSE·samples, the 8-bit figure's, per θl group.
class ReconstructionSums {
 public:
  void Add(const ReconstructionMetrics& part, int theta_group);
  ReconstructionMetrics Metrics() const;  // srgb8 figures when every part had them

 private:
  double sse_ = 0, sse8_ = 0, samples_ = 0;
  bool srgb8_ = true;
  std::map<int, std::pair<double, double>> by_theta_;  // θl → (Σ dev%·n, Σ n)
};

struct TruthMetrics {
  // A model without a fitted normal (mean, ptm, hsh) or whose albedo map is not a diffuse albedo
  // (mean, heinrich's mean texture, ptm/hsh frontal value) is not scored on it.
  bool has_normal = false, has_albedo = false;
  double normal_mae_deg = 0, normal_p95_deg = 0;  // angle between fitted and true normals
  double albedo_rmse = 0;                         // over channels (diffuse albedo)
  int64_t texels = 0;
  // Model-specific parameters present in both maps: median relative error of the Blinn–Phong
  // exponent and Cook–Torrance roughness, median absolute error of k_s / F0 ("specular").
  std::map<std::string, double> parameter_errors;
};

// Per texel: RMS over `lights` (unit directions) and channels of the fitted maps' forward
// evaluation minus the truth's (local shading, no cast shadows): the relighting error a
// renderer would show, in linear radiance per unit light. NaN outside the truth mask. Both are
// taken up to `recorded_limit` per channel (r, g, b), min(v, limit): the error within a camera's
// recorded range (fit/confidence.h Confidence::recorded_limit); +inf: unlimited.
std::vector<float> RelightingError(const MaterialMaps& fitted, const MaterialMaps& truth,
                                   const std::vector<Vec3>& lights, const Vec3& view,
                                   const Vec3& recorded_limit = Vec3(INFINITY, INFINITY, INFINITY));
// The same against truth images instead of truth maps (a material whose appearance is no model's,
// e.g. synth::RenderMicroStack over the directions): per texel, RMS over the stack's lights and
// channels of the fitted evaluation minus sample / intensity. NaN outside the stack's mask.
std::vector<float> RelightingError(const MaterialMaps& fitted, const LightStack& truth);

// Cost of the model's batched CPU evaluation on these maps (the renderer's and the metrics'
// path): ns per texel × light (3 channels), median of 3 timed passes over 4 light directions.
// A measurement, not a model.
double ShadingCostNs(const MaterialMaps& maps);

// Over texels with status 0 inside the truth mask.
TruthMetrics CompareToTruth(const MaterialMaps& fitted, const MaterialMaps& truth,
                            const std::vector<uint8_t>& status);

}  // namespace matfit::fit
