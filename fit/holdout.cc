#include "fit/holdout.h"

#include <cmath>

#include "fit/metrics.h"
#include "fit/per_view_fit.h"
#include "fit/score.h"

namespace matfit::fit {

StatusOr<HeldOutMetrics> HeldOut(const FitMethod& method, const LightStack& s, int folds,
                                 const FitOptions& options) {
  const int n = s.num_images();
  if (folds == kLeaveOneOut) folds = n;
  if (folds < 2 || folds > n)
    return InvalidArgument("--holdout must be between 2 and the number of images (" +
                           std::to_string(n) + "), got " + std::to_string(folds));
  HeldOutMetrics h;
  h.folds = folds;
  double total = 0, total_common = 0, total8 = 0, total8_common = 0;
  std::map<int, std::pair<double, int64_t>> groups;
  FitOptions o = options;
  bool cancelled = false;
  std::vector<double> texel_rss(size_t(s.plane_size()), 0.0);
  std::vector<int64_t> texel_samples(size_t(s.plane_size()), 0);
  for (int f = 0; f < folds; ++f) {
    // The caller's progress sees the folds as one job: fold f's tiles map to [f, f+1) / folds.
    if (options.progress)
      o.progress = [&, f](int64_t d, int64_t t) {
        const bool go = options.progress(int64_t(f) * t + d, int64_t(folds) * t);
        cancelled = cancelled || !go;
        return go;
      };
    std::vector<int> train, test;
    for (int i = 0; i < n; ++i) (i % folds == f ? test : train).push_back(i);
    auto fit = method.Fit(BorrowImages(s, train), o);  // no copy of the training images
    if (cancelled || (!fit.ok() && fit.status().code() == StatusCode::kCancelled))
      return Status(StatusCode::kCancelled, "cancelled");
    if (!fit.ok()) {
      ++h.failed_folds;
      continue;
    }
    // A per-view fit predicts each image from its own view's maps (fit/per_view_fit.h).
    // The common texel set's figures from the same pass when they differ (flagged texels).
    const bool common = AnyFlagged(s, fit->status) || !fit->views.empty();
    StackScore score =
        ScoreFit(s, test, *fit, /*common=*/false, {},
                 {.reconstruction = true, .residuals = true, .srgb8 = true, .common = common});
    const ReconstructionMetrics& m = score.reconstruction;
    for (size_t p = 0; p < texel_rss.size(); ++p)
      texel_rss[p] += score.residuals.rss[p], texel_samples[p] += score.residuals.samples[p];
    total += m.deviation_percent / 100 * double(m.samples);
    h.samples += m.samples;
    const ReconstructionMetrics& mc = common ? score.reconstruction_common : m;
    total_common += mc.deviation_percent / 100 * double(mc.samples);
    total8 += m.rmse_srgb8 * m.rmse_srgb8 * double(m.samples);
    total8_common += mc.rmse_srgb8 * mc.rmse_srgb8 * double(mc.samples);
    h.samples_common += mc.samples;
    // Every held-out image contributes the same number of samples (one status plane).
    for (const auto& [t, d] : m.deviation_percent_by_theta) {
      int64_t count = 0;
      for (size_t k = 0; k < test.size(); ++k)
        if (int(std::lround(s.lights()[size_t(test[k])].theta_deg / 15.0)) * 15 == t) count++;
      const int64_t samples = m.samples / int64_t(test.size()) * count;
      groups[t].first += d / 100 * double(samples);
      groups[t].second += samples;
    }
  }
  if (h.samples == 0)
    return InvalidArgument(method.name() + ": no fold could be fitted with " +
                           std::to_string(folds) + " folds over " + std::to_string(n) +
                           " images; use fewer folds");
  const double mse = total / double(h.samples);
  h.rmse = std::sqrt(mse);
  h.deviation_percent = 100 * mse;
  h.psnr_db = mse > 0 ? 10 * std::log10(1 / mse) : INFINITY;
  const double mse_common = h.samples_common ? total_common / double(h.samples_common) : 0;
  h.rmse_common = std::sqrt(mse_common);
  h.psnr_db_common = mse_common > 0 ? 10 * std::log10(1 / mse_common) : INFINITY;
  const auto srgb8 = [](double sum, int64_t samples, double* rmse, double* psnr) {
    if (samples == 0) return;
    const double mse8 = sum / double(samples);
    *rmse = std::sqrt(mse8);
    *psnr = mse8 > 0 ? 10 * std::log10(255.0 * 255.0 / mse8) : INFINITY;
  };
  srgb8(total8, h.samples, &h.rmse_srgb8, &h.psnr_srgb8_db);
  srgb8(total8_common, h.samples_common, &h.rmse_srgb8_common, &h.psnr_srgb8_db_common);
  h.texel_rmse.assign(texel_rss.size(), NAN);
  for (size_t p = 0; p < texel_rss.size(); ++p)
    if (texel_samples[p] > 0)
      h.texel_rmse[p] = float(std::sqrt(texel_rss[p] / double(texel_samples[p])));
  for (auto& [t, g] : groups)
    h.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return h;
}

}  // namespace matfit::fit
