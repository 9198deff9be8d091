// Held-out-light error: the honest metric on real data. K folds over the images (image i in
// fold i mod K); each fold is predicted by a fit on the other images.
#pragma once

#include <map>

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
};

// folds ≥ 2 and ≤ number of images; a fold that leaves the method without enough lights is
// counted in failed_folds. options.progress, when set, sees all folds as one job (tiles over
// folds × tiles); returning false cancels (kCancelled).
StatusOr<HeldOutMetrics> HeldOut(const FitMethod& method, const LightStack& stack, int folds,
                                 const FitOptions& options);

}  // namespace matfit::fit
