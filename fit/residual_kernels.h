// The per-run kernels shared by the passes that compare the stack with a model's predictions
// (fit/metrics.cc Reconstruction, fit/confidence.cc ComputeConfidence, fit/score.cc ScoreStack),
// so that a fused pass computes bit for bit what the separate ones do. Internal to fit/.
#pragma once

#include <cstdint>
#include <vector>

#include "fit/metrics.h"

namespace matfit::fit {

// Σ_t [ok_t ≠ 0] (obs_t − I · pred_t)² over n texels: the difference in float, its square summed
// in double in a fixed order (independent of the ISA clone).
double SumSquaredDiff(const float* obs, const float* pred, float intensity, const float* ok, int n);

// The confidence bound's per-light sums over n texels: q = raw · inv, r = q − pred for samples
// that are finite and below clip_level; acc += r², sum += |q|, k += 1, used |= 1.
void ResidualSums(const float* raw, const float* pred, float inv, float clip_level, int n,
                  double* acc, double* sum, int* k, int* used);

// Reconstruction metrics from per-run, per-light sums (run_sum[r · n + i], run_count likewise,
// n = images.size()), added in run order.
ReconstructionMetrics ReduceReconstruction(const LightStack& stack, const std::vector<int>& images,
                                           const std::vector<double>& run_sum,
                                           const std::vector<int64_t>& run_count, int64_t runs);

}  // namespace matfit::fit
