// Held-out-light error: the honest metric on real data. K folds over the images (image i in
// fold i mod K); each fold is predicted by a fit on the other images.
#pragma once

#include <cmath>
#include <map>
#include <vector>

#include "core/light_stack.h"
#include "fit/method.h"

namespace matfit::fit {

struct HeldOutMetrics {
  int folds = 0;
  double rmse = 0, deviation_percent = 0, psnr_db = 0;
  std::map<int, double> deviation_percent_by_theta;
  int failed_folds = 0;  // folds whose fit failed (e.g. too few lights left): not scored
  int64_t samples = 0;
  // The same over the common texel set (fit/metrics.h CommonTexelStatus): every unmasked texel,
  // flagged ones with their stored values — comparable across models.
  double rmse_common = 0, psnr_db_common = 0;
  int64_t samples_common = 0;
  // In 8-bit sRGB codes (fit/metrics.h ReconstructionMetrics::psnr_srgb8_db), over the fitted
  // and over the common texel set.
  double rmse_srgb8 = NAN, psnr_srgb8_db = NAN, rmse_srgb8_common = NAN, psnr_srgb8_db_common = NAN;
  // Per texel: the RMS of q − pred (q = raw / I, the unit of the error bound, fit/confidence.h)
  // over its held-out samples that are finite and unclipped, in the folds that fitted it; NaN
  // where there was none. What the bound-to-actual ratio compares the bound with.
  std::vector<float> texel_rmse;
};

// Leave-one-out: as many folds as images (`--holdout loo`).
inline constexpr int kLeaveOneOut = -1;

// folds ≥ 2 and ≤ number of images, or kLeaveOneOut; a fold that leaves the method without enough
// lights is counted in failed_folds. options.progress, when set, sees all folds as one job (tiles
// over folds × tiles); returning false cancels (kCancelled).
StatusOr<HeldOutMetrics> HeldOut(const FitMethod& method, const LightStack& stack, int folds,
                                 const FitOptions& options);

}  // namespace matfit::fit
