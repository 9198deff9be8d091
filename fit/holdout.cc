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
  double total = 0;
  std::map<int, std::pair<double, int64_t>> groups;
  FitOptions o = options;
  o.progress = nullptr;
  for (int f = 0; f < folds; ++f) {
    std::vector<int> train, test;
    for (int i = 0; i < n; ++i) (i % folds == f ? test : train).push_back(i);
    auto fit = method.Fit(SelectImages(s, train), o);
    if (!fit.ok()) {
      ++h.failed_folds;
      continue;
    }
    const LightStack held = SelectImages(s, test);
    const ReconstructionMetrics m = Reconstruction(held, fit->maps, fit->status);
    total += m.deviation_percent / 100 * double(m.samples);
    h.samples += m.samples;
    // Every held-out image contributes the same number of samples (one status plane).
    for (const auto& [t, d] : m.deviation_percent_by_theta) {
      int64_t count = 0;
      for (size_t k = 0; k < test.size(); ++k)
        if (int(std::lround(held.lights()[k].theta_deg / 15.0)) * 15 == t) count++;
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
  for (auto& [t, g] : groups)
    h.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return h;
}

}  // namespace matfit::fit
