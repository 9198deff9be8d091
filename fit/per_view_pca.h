// The data-driven reference of a multi-view fit (issue 17): per-view PCA of the reflectance field
// (Sattler et al. 2003). For each view, every texel's samples over that view's lights and
// channels (a vector of L·C intensity-normalised values) is approximated by the view's mean
// vector plus its k leading principal components; the error is what k components cannot hold,
// the eigenvalues beyond the k-th of the view's covariance. This measures what analytic models
// miss at a given storage, not a model that predicts other views or lights.
#pragma once

#include <cstdint>
#include <vector>

#include "core/light_stack.h"
#include "core/progress_fn.h"

namespace matfit::fit {

struct PcaPoint {
  int k = 0;
  // Storing it: k half-float weights per texel and view, plus each view's mean and k basis
  // vectors as floats shared by the texels.
  double bytes_per_texel = 0;
  double rmse = 0;  // over every sample of every view (texels with a non-finite sample skipped)
};

// One point per k in `ks` (k ≥ 1, capped at L·C of each view); texels where `status` is non-zero
// are left out (empty: every texel). Parallel over texels; the covariance sums are double.
// `progress` (display only) counts views.
std::vector<PcaPoint> PerViewPcaCurve(const LightStack& stack, const std::vector<int>& ks,
                                      const std::vector<uint8_t>& status = {},
                                      const ProgressFn& progress = {});

}  // namespace matfit::fit
