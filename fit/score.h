// One pass over the stack that predicts every image from the fitted maps and scores it twice:
// the reconstruction metrics (fit/metrics.h) and the per-texel residual sums of the error bound
// (fit/confidence.h). Reconstruction() and ComputeConfidence() run it for their part; `matfit
// fit` runs it once for both.
#pragma once

#include <cstdint>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "fit/metrics.h"

namespace matfit::fit {

// Per texel x over the lights: Σ r² of r = q − pred, q = raw / I, over finite unclipped samples
// and over the clipped samples (at the file's maximum code) that the prediction undershoots — in
// the range the camera recorded, a clipped sample's error is max(0, q − pred) — (rss), the mean
// |q| of those samples (level), their count n_x, the lights with at least one finite unclipped
// sample m_x, and the lights with a clipped sample (clipped_lights: the texel's appearance
// reached the clip level there). Zero for texels whose status is not ok.
struct TexelResiduals {
  std::vector<double> rss, level;
  std::vector<int> samples, used_lights, clipped_lights;
};

struct StackScore {
  ReconstructionMetrics reconstruction;  // empty unless asked for
  // ScoreParts::common: the reconstruction over CommonTexelStatus(status) (fit/metrics.h).
  ReconstructionMetrics reconstruction_common;
  TexelResiduals residuals;  // empty unless asked for
};

struct ScoreParts {
  bool reconstruction = true;
  bool residuals = true;
  // With reconstruction: also the error in 8-bit sRGB codes (ReconstructionMetrics::rmse_srgb8),
  // both the sample and I · prediction encoded as LinearToSrgb8Fast does (batched); a table pass
  // per sample, so only held-out scoring asks for it.
  bool srgb8 = false;
  // With reconstruction: also its figures over the common texel set, CommonTexelStatus(status)
  // (every texel but the masked ones), in the same pass: each light's samples and predictions
  // are summed a second time with the other weights, so the figures are those of a pass with
  // that status (the same sums in the same order), without predicting and decoding again.
  bool common = false;
};

// Over images `images` of the stack (held-out folds score their test images in place). Texels
// whose status is not 0 (ok) are skipped by both parts (status may be empty: all texels).
// Batched: runs of kEvalRun texels in parallel, each light's constants once, sums in run order
// (the same for any thread count); `progress` gets runs done / total.
StackScore ScoreStack(const LightStack& stack, const std::vector<int>& images,
                      const MaterialMaps& maps, const std::vector<uint8_t>& status,
                      const ProgressFn& progress = {}, ScoreParts parts = {});
// The same over every image.
StackScore ScoreStack(const LightStack& stack, const MaterialMaps& maps,
                      const std::vector<uint8_t>& status, const ProgressFn& progress = {},
                      ScoreParts parts = {});

}  // namespace matfit::fit
