#include "eval/multi_view_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/synth/synth.h"
#include "fit/holdout_views.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "fit/per_view_fit.h"
#include "fit/per_view_pca.h"

namespace matfit::eval {
namespace {

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

}  // namespace

std::vector<MultiViewCase> MultiViewSuite(bool quick) {
  MultiViewCase c;
  if (quick) {
    c.name = "lacquer-views-24", c.views = "dome:25", c.size = 24, c.holdout_views = 6;
    return {c};
  }
  // 81 × 81 as a Bonn BTF; 128² is the size (≈ 5 minutes on 2 cores).
  c.name = "lacquer-views-48", c.views = "bonn81", c.size = 48, c.holdout_views = 8;
  MultiViewCase big = c;
  big.name = "lacquer-views-128", big.size = 128;
  return {c, big};
}

StatusOr<std::vector<MultiViewPoint>> RunMultiViewCase(const MultiViewCase& c,
                                                       const MultiViewMethods& methods, int repeats,
                                                       const ProgressFn& progress) {
  synth::SynthOptions so;
  so.material = c.material, so.lights = c.lights, so.views = c.views, so.size = c.size;
  so.layout = Layout::kBonn, so.bits = 32;
  auto data = synth::Synthesize(so);
  if (!data.ok()) return data.status();
  const LightStack& s = data->stack;
  const auto groups = ViewGroups(s);
  if (int(groups.size()) <= c.holdout_views)
    return InvalidArgument("multi-view case " + c.name + ": " + std::to_string(groups.size()) +
                           " views cannot leave " + std::to_string(c.holdout_views) + " out");
  const std::vector<int> held = fit::ChooseHeldOutViews(s, groups, c.holdout_views);
  std::vector<int> train, test;
  fit::SplitByViews(groups, held, &train, &test);
  const LightStack train_stack = SelectImages(s, train);
  const LightStack front = SelectView(s, groups[size_t(MostFrontalView(s, groups))]);
  const int train_views = int(groups.size()) - c.holdout_views;
  const int64_t texels = s.plane_size();
  const int total = int(methods.joint.size() + methods.per_view.size() + methods.frontal.size()) +
                    (methods.pca_ks.empty() ? 0 : 1);
  int done = 0;
  std::vector<MultiViewPoint> points;
  auto fit_point = [&](const std::string& name, const std::string& family) {
    MultiViewPoint p;
    p.dataset = c.name, p.method = name, p.family = family;
    const auto method = fit::MakeMethod(name);
    if (!method) {
      p.ok = false, p.error = "not a method";
      return p;
    }
    const LightStack& fitted = family == "frontal" ? front : train_stack;
    std::vector<double> seconds;
    StatusOr<fit::FitResult> fit = Status(StatusCode::kInternal, "not run");
    for (int r = 0; r < std::max(1, repeats); ++r) {
      const auto t0 = Clock::now();
      fit = method->Fit(fitted, {});
      seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      if (!fit.ok()) break;
    }
    if (!fit.ok()) {
      p.ok = false, p.error = fit.status().message();
      return p;
    }
    p.fit_seconds = Median(seconds);
    p.texels_per_second = double(texels) / p.fit_seconds;
    const int views = family == "per-view" ? train_views : 1;
    p.bytes_per_texel = double(method->bytes_per_texel()) * views;
    // Each held-out image at its own view (a per-view fit through its nearest fitted view), over
    // the common texel set (every unmasked texel, as bench scores single-view cases).
    const fit::StackScore score = fit::ScoreFit(s, test, *fit, /*common=*/true, {},
                                                {.reconstruction = true, .residuals = true});
    p.heldout_view_rmse = score.reconstruction.rmse;
    double sum = 0, scored = 0;
    for (size_t t = 0; t < score.residuals.rss.size(); ++t)
      if (score.residuals.samples[t] > 0)
        sum += std::sqrt(score.residuals.rss[t] / score.residuals.samples[t]), ++scored;
    p.heldout_view_texel_rms = scored > 0 ? sum / scored : NAN;
    std::map<int, fit::ReconstructionSums> by_view;
    for (int g : held) {
      double theta = 0, phi = 0;
      AnglesDegFromDirection(s.ViewOf(groups[size_t(g)][0]), &theta, &phi);
      by_view[int(std::lround(theta / 15)) * 15].Add(
          fit::ScoreFit(s, groups[size_t(g)], *fit, /*common=*/true, {},
                        {.reconstruction = true, .residuals = false})
              .reconstruction,
          0);
    }
    for (const auto& [tv, sums] : by_view) p.heldout_view_rmse_by_theta[tv] = sums.Metrics().rmse;
    p.normal_mae_deg = fit::CompareToTruth(fit->maps, data->truth, fit->status).normal_mae_deg;
    return p;
  };
  auto step = [&] { return !progress || progress(++done, total); };
  for (const auto& m : methods.joint) {
    points.push_back(fit_point(m, "joint"));
    if (!step()) return Status(StatusCode::kCancelled, "cancelled");
  }
  for (const auto& m : methods.per_view) {
    points.push_back(fit_point(m, "per-view"));
    if (!step()) return Status(StatusCode::kCancelled, "cancelled");
  }
  for (const auto& m : methods.frontal) {
    points.push_back(fit_point(m, "frontal"));
    if (!step()) return Status(StatusCode::kCancelled, "cancelled");
  }
  if (!methods.pca_ks.empty()) {
    // Over the unmasked texels, as the fits are scored (status: the mask only).
    std::vector<uint8_t> masked;
    if (s.has_mask()) {
      masked.assign(size_t(s.plane_size()), 0);
      for (size_t p = 0; p < masked.size(); ++p) masked[p] = s.mask[p] ? 0 : fit::kTexelMasked;
    }
    for (const fit::PcaPoint& pt : fit::PerViewPcaHeldOutViews(s, held, methods.pca_ks, masked)) {
      MultiViewPoint p;
      p.dataset = c.name, p.family = "pca", p.k = pt.k;
      p.method = "pca-k" + std::to_string(pt.k);
      p.bytes_per_texel = pt.bytes_per_texel;
      p.heldout_view_rmse = pt.rmse;
      p.heldout_view_texel_rms = pt.texel_rms_mean;
      p.heldout_view_rmse_by_theta = pt.rmse_by_view_theta;
      points.push_back(p);
    }
    if (!step()) return Status(StatusCode::kCancelled, "cancelled");
  }
  return points;
}

}  // namespace matfit::eval
