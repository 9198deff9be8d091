// The data-driven reference of a multi-view fit (issue 17): per-view PCA of the reflectance field
// (Sattler et al. 2003). For each view, every texel's samples over that view's lights and
// channels (a vector of L·C intensity-normalised values) is approximated by the view's mean
// vector plus its k leading principal components; the error is what k components cannot hold,
// the eigenvalues beyond the k-th of the view's covariance. This measures what analytic models
// miss at a given storage, not a model that predicts other views or lights.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <vector>

#include "core/image.h"
#include "core/light_stack.h"
#include "core/progress_fn.h"

namespace matfit::fit {

struct PcaPoint {
  int k = 0;
  // Storing it: k half-float weights per texel and view, plus each view's mean and k basis
  // vectors as floats shared by the texels.
  double bytes_per_texel = 0;
  double rmse = 0;  // over every sample of every view (texels with a non-finite sample skipped)
  // PerViewPcaHeldOutViews: the mean over texels of each texel's RMS over its held-out samples
  // (every texel weighs the same; the pooled rmse is led by the few brightest samples).
  double texel_rms_mean = NAN;
  // PerViewPcaHeldOutViews: the pooled RMSE of the held-out views per θv (rounded to 15°).
  std::map<int, double> rmse_by_view_theta;
};

// One point per k in `ks` (k ≥ 1, capped at L·C of each view); texels where `status` is non-zero
// are left out (empty: every texel). Parallel over texels; the covariance sums are double.
// `progress` (display only) counts views.
std::vector<PcaPoint> PerViewPcaCurve(const LightStack& stack, const std::vector<int>& ks,
                                      const std::vector<uint8_t>& status = {},
                                      const ProgressFn& progress = {});

// The stored form of one view's PCA with k components (a pack's pca/ folder, docs/pack.md): the
// sample of image a (of the view's L, in stack order), channel c, at texel x is
//   I_{a,c} · (basis(a·C + c, 0) + Σ_{j=1..k} weights_j(x) · basis(a·C + c, j))
// with basis one channel of width L·C and height k + 1 (row 0 the mean, row j the j-th component,
// largest first) and weights a texel-sized image of k channels (0 where a texel was left out).
struct ViewPcaModel {
  double theta_deg = 0, phi_deg = 0;
  std::vector<int> images;  // the view's images in the stack
  Image weights, basis;
};

// Every view's model at k components (k ≥ 1, capped at L·C), texels as PerViewPcaCurve uses
// them; its reconstruction RMSE is PerViewPcaCurve's at k. `progress` counts views.
std::vector<ViewPcaModel> PerViewPcaModels(const LightStack& stack, int k,
                                           const std::vector<uint8_t>& status = {},
                                           const ProgressFn& progress = {});

// Per-view PCA as a predictor of views it was not made from: each view of `held` (indices into
// ViewGroups) predicted by the k-component reconstruction of the nearest other view (largest
// cosine), each held-out image by that view's image of the nearest light — the nearest-view
// lookup a per-view BTF renderer does. rmse over the held-out views' finite, unclipped samples
// (as ScoreStack counts them; texels with status ≠ 0 or a non-finite training sample left out);
// bytes_per_texel of the PCA of the other views. `progress` counts held-out views.
std::vector<PcaPoint> PerViewPcaHeldOutViews(const LightStack& stack, const std::vector<int>& held,
                                             const std::vector<int>& ks,
                                             const std::vector<uint8_t>& status = {},
                                             const ProgressFn& progress = {});

}  // namespace matfit::fit
