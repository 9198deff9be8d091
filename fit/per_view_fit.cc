#include "fit/per_view_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "fit/holdout_views.h"
#include "fit/metrics.h"

namespace matfit::fit {
namespace {

int Group15(double deg) { return int(std::lround(deg / 15.0)) * 15; }

std::string ViewLabel(const ViewFit& v) {
  char s[48];
  std::snprintf(s, sizeof s, "view %.4g,%.4g", v.theta_deg, v.phi_deg);
  return s;
}

class PerViewMethod : public FitMethod {
 public:
  explicit PerViewMethod(std::unique_ptr<FitMethod> base) : base_(std::move(base)) {}
  std::string name() const override { return kPerViewPrefix + base_->name(); }
  std::string description() const override {
    return base_->description() + "; fitted to each view on its own (maps per view)";
  }
  int parameters_per_texel() const override { return base_->parameters_per_texel(); }
  int bytes_per_texel() const override { return base_->bytes_per_texel(); }
  int light_parameters() const override { return base_->light_parameters(); }
  int parameters_per_channel() const override { return base_->parameters_per_channel(); }
  const FitMethod& base() const { return *base_; }

  StatusOr<FitResult> Fit(const LightStack& s, const FitOptions& o) const override {
    if (s.has_light_positions() && s.is_multi_view())
      return InvalidArgument(name() +
                             ": near lights (light_positions.txt) over several views are not "
                             "supported; use --distant-lights");
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<std::vector<int>> groups = ViewGroups(s);
    const int V = int(groups.size());
    FitResult r;
    r.method = name();
    r.frontal_view = MostFrontalView(s, groups);
    r.views.reserve(size_t(V));
    bool cancelled = false;
    for (int g = 0; g < V; ++g) {
      FitOptions fo = o;  // view g's tiles as [g, g + 1) of the V views
      if (o.progress)
        fo.progress = [&, g](int64_t d, int64_t t) {
          const bool go = t <= 0 || o.progress(int64_t(g) * t + d, int64_t(V) * t);
          cancelled = cancelled || !go;
          return go;
        };
      const LightStack view = SelectView(s, groups[size_t(g)]);
      ViewFit vf;
      vf.theta_deg = view.view_theta_deg, vf.phi_deg = view.view_phi_deg;
      vf.view = view.view_direction;
      auto fit = base_->Fit(view, fo);
      if (cancelled || (!fit.ok() && fit.status().code() == StatusCode::kCancelled))
        return Status(StatusCode::kCancelled, "cancelled");
      if (!fit.ok())
        return Status(fit.status().code(),
                      name() + ": " + ViewLabel(vf) + ": " + fit.status().message());
      for (const std::string& w : fit->warnings)  // each distinct warning once
        if (std::find(r.warnings.begin(), r.warnings.end(), w) == r.warnings.end())
          r.warnings.push_back(w);
      if (g == r.frontal_view) {
        r.maps = fit->maps, r.status = fit->status;
        r.parameters.insert(fit->parameters.begin(), fit->parameters.end());
        r.flagged_texels = fit->flagged_texels;
        r.dropped_lights = fit->dropped_lights;
        r.refit_texels = fit->refit_texels, r.dropped_samples = fit->dropped_samples;
      }
      vf.maps = std::move(fit->maps), vf.status = std::move(fit->status);
      vf.parameters = std::move(fit->parameters);  // its own (a lobe shape per view)
      r.views.push_back(std::move(vf));
    }
    r.parameters["views"] = V;
    r.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  }

 private:
  std::unique_ptr<FitMethod> base_;
};

}  // namespace

std::unique_ptr<FitMethod> MakePerViewMethod(const std::string& base) {
  const std::vector<std::string> ladder = MethodNames();
  if (std::find(ladder.begin(), ladder.end(), base) == ladder.end()) return nullptr;
  return std::make_unique<PerViewMethod>(MakeMethod(base));
}

const FitMethod* PerViewBase(const FitMethod& method) {
  const auto* p = dynamic_cast<const PerViewMethod*>(&method);
  return p ? &p->base() : nullptr;
}

int NearestViewFit(const FitResult& fit, const Vec3& view) {
  int best = 0;
  for (int v = 1; v < int(fit.views.size()); ++v)
    if (Dot(fit.views[size_t(v)].view, view) > Dot(fit.views[size_t(best)].view, view) + 1e-12)
      best = v;
  return best;
}

StackScore ScoreFit(const LightStack& s, const std::vector<int>& images, const FitResult& fit,
                    bool common, const ProgressFn& progress, ScoreParts parts) {
  if (fit.views.empty())
    return ScoreStack(s, images, fit.maps, common ? CommonTexelStatus(fit.status) : fit.status,
                      progress, parts);
  // Images by (nearest fitted view, θl group): each part's figures are exact sums.
  std::map<std::pair<int, int>, std::vector<int>> split;
  for (int i : images)
    split[{NearestViewFit(fit, s.ViewOf(i)), Group15(s.lights()[size_t(i)].theta_deg)}].push_back(
        i);
  std::map<int, std::vector<uint8_t>> common_status;  // per view, made when first needed
  StackScore out;
  const size_t T = size_t(s.plane_size());
  if (parts.residuals) {
    TexelResiduals& r = out.residuals;
    r.rss.assign(T, 0.0), r.level.assign(T, 0.0), r.samples.assign(T, 0),
        r.used_lights.assign(T, 0), r.clipped_lights.assign(T, 0);
  }
  ReconstructionSums sums, sums_common;
  int64_t done = 0;
  for (const auto& [key, part] : split) {
    // Display only under MPI (each part is collective: every rank scores every part).
    if (progress && !progress(done++, int64_t(split.size())) && !s.is_band()) break;
    const ViewFit& v = fit.views[size_t(key.first)];
    const std::vector<uint8_t>* status = &v.status;
    if (common) {
      auto it = common_status.find(key.first);
      if (it == common_status.end())
        it = common_status.emplace(key.first, CommonTexelStatus(v.status)).first;
      status = &it->second;
    }
    const StackScore sc = ScoreStack(s, part, v.maps, *status, {}, parts);
    if (parts.reconstruction) sums.Add(sc.reconstruction, key.second);
    if (parts.reconstruction && parts.common) sums_common.Add(sc.reconstruction_common, key.second);
    if (parts.residuals) {
      TexelResiduals& r = out.residuals;
      const TexelResiduals& p = sc.residuals;
      for (size_t t = 0; t < T; ++t) {
        r.rss[t] += p.rss[t], r.level[t] += p.level[t] * p.samples[t];
        r.samples[t] += p.samples[t], r.used_lights[t] += p.used_lights[t];
        r.clipped_lights[t] += p.clipped_lights[t];
      }
    }
  }
  if (progress) progress(int64_t(split.size()), int64_t(split.size()));
  if (parts.residuals)
    for (size_t t = 0; t < T; ++t)
      if (out.residuals.samples[t] > 0) out.residuals.level[t] /= out.residuals.samples[t];
  if (parts.reconstruction) out.reconstruction = sums.Metrics();
  if (parts.reconstruction && parts.common) out.reconstruction_common = sums_common.Metrics();
  return out;
}

StackScore ScoreFit(const LightStack& s, const FitResult& fit, bool common,
                    const ProgressFn& progress, ScoreParts parts) {
  std::vector<int> all(size_t(s.num_images()));
  for (int i = 0; i < s.num_images(); ++i) all[size_t(i)] = i;
  return ScoreFit(s, all, fit, common, progress, parts);
}

std::map<int, std::map<int, double>> DeviationByViewTheta(const LightStack& s,
                                                          const FitResult& fit) {
  ViewThetaSums sums;
  AddDeviationByViewTheta(
      s,
      [&](const Vec3& view) {
        const ViewFit& v = fit.views[size_t(NearestViewFit(fit, view))];
        return std::pair(&v.maps, &v.status);
      },
      &sums);
  return DeviationByViewTheta(sums);
}

}  // namespace matfit::fit
