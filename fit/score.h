// One pass over the stack that predicts every image from the fitted maps and scores it twice:
// the reconstruction metrics (fit/metrics.h) and the per-texel residual sums of the error bound
// (fit/confidence.h). `matfit fit` runs it once instead of one pass for each; the results are
// bit for bit those of Reconstruction() and ComputeConfidence()'s own pass.
#pragma once

#include <cstdint>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "fit/metrics.h"

namespace matfit::fit {

// Per texel x over the lights: Σ r² of q = raw / I − pred over finite unclipped samples (rss),
// the mean |q| (level), the sample count n_x and the lights with at least one such sample m_x.
// Zero for texels whose status is not ok.
struct TexelResiduals {
  std::vector<double> rss, level;
  std::vector<int> samples, used_lights;
};

struct StackScore {
  ReconstructionMetrics reconstruction;  // empty unless asked for
  TexelResiduals residuals;
};

// Texels whose status is not 0 (ok) are skipped by both (status may be empty: all texels).
// Batched: runs of kEvalRun texels in parallel, each light's constants once; `progress` gets
// runs done / total.
StackScore ScoreStack(const LightStack& stack, const MaterialMaps& maps,
                      const std::vector<uint8_t>& status, const ProgressFn& progress = {},
                      bool reconstruction = true);

}  // namespace matfit::fit
