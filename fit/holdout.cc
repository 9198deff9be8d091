#include "fit/holdout.h"

#include <cmath>

#include "fit/metrics.h"

namespace matfit::fit {

StatusOr<HeldOutMetrics> HeldOut(const FitMethod& method, const LightStack& s, int folds,
                                 const FitOptions& options) {
  const int n = s.num_images();
  if (folds < 2 || folds > n)
    return InvalidArgument("--holdout must be between 2 and the number of images (" +
                           std::to_string(n) + "), got " + std::to_string(folds));
  HeldOutMetrics h;
  h.folds = folds;
  double total = 0, total_common = 0;
  std::map<int, std::pair<double, int64_t>> groups;
  FitOptions o = options;
  bool cancelled = false;
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
    auto fit = method.Fit(SelectImages(s, train), o);
    if (cancelled || (!fit.ok() && fit.status().code() == StatusCode::kCancelled))
      return Status(StatusCode::kCancelled, "cancelled");
    if (!fit.ok()) {
      ++h.failed_folds;
      continue;
    }
    const ReconstructionMetrics m = Reconstruction(s, test, fit->maps, fit->status);
    total += m.deviation_percent / 100 * double(m.samples);
    h.samples += m.samples;
    const ReconstructionMetrics mc =
        AnyFlagged(fit->status) ? Reconstruction(s, test, fit->maps, CommonTexelStatus(fit->status))
                                : m;
    total_common += mc.deviation_percent / 100 * double(mc.samples);
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
  for (auto& [t, g] : groups)
    h.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return h;
}

}  // namespace matfit::fit
