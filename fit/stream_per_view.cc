#include "fit/stream_per_view.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/dataset/info.h"
#include "fit/per_view_fit.h"
#include "fit/score.h"

namespace matfit::fit {
namespace {

int Group15(double deg) { return int(std::lround(deg / 15.0)) * 15; }

// Every image of a single-view stack scored with maps, one part per θl group (exact sums).
void AddScores(const LightStack& view, const MaterialMaps& maps, const std::vector<uint8_t>& status,
               bool srgb8, ReconstructionSums* sums, ReconstructionSums* also = nullptr) {
  std::map<int, std::vector<int>> by_light;
  for (int i = 0; i < view.num_images(); ++i)
    by_light[Group15(view.lights()[size_t(i)].theta_deg)].push_back(i);
  for (const auto& [tl, images] : by_light) {
    const ReconstructionMetrics m =
        ScoreStack(view, images, maps, status, {},
                   {.reconstruction = true, .residuals = false, .srgb8 = srgb8})
            .reconstruction;
    sums->Add(m, tl);
    if (also) also->Add(m, tl);
  }
}

}  // namespace

StatusOr<StreamedPerView> FitPerViewOutOfCore(const std::string& input, const ReadOptions& read,
                                              const LightStack& shape, const FitMethod& method,
                                              const FitOptions& o, const std::vector<int>& held,
                                              const ProgressFn& progress) {
  const FitMethod* base = PerViewBase(method);
  if (!base) return InvalidArgument(method.name() + " is not a per-view method");
  const auto t0 = std::chrono::steady_clock::now();
  const auto groups = ViewGroups(shape);
  const int V = int(groups.size());
  const int frontal = MostFrontalView(shape, groups);
  for (int h : held)
    if (h < 0 || h >= V || h == frontal)
      return InvalidArgument("held-out view " + std::to_string(h) + " is not one of the " +
                             std::to_string(V) + " views other than the most frontal");
  if (int(held.size()) >= V) return InvalidArgument("every view held out: nothing to fit");
  const int64_t steps = V + int64_t(held.size());
  // The most frontal view first: the tone curve estimated on it applies to every view, as an
  // in-memory read of every view does (fit/diagnostics.h).
  std::vector<int> order{frontal};
  for (int g = 0; g < V; ++g)
    if (g != frontal) order.push_back(g);
  // One view read alone: the images of group g, checked (by light) against the headers, with
  // the mask of every view when the images' alpha gives it (an in-memory read of every view ANDs
  // every image's alpha).
  std::vector<uint8_t> all_mask;
  auto read_view = [&](int g) -> StatusOr<LightStack> {
    const LightSample& l = shape.lights()[size_t(groups[size_t(g)][0])];
    ReadOptions one = read;
    one.all_views = false;
    one.progress = {};
    one.view = ViewAngles{l.view_theta_deg, l.view_phi_deg};
    auto v = ReadDataset(input, one);
    if (!v.ok()) return v;
    if (v->num_images() != int(groups[size_t(g)].size()) ||
        Length(v->view_direction - shape.ViewOf(groups[size_t(g)][0])) > 1e-6)
      return DataError("view " + std::to_string(l.view_theta_deg) + "," +
                       std::to_string(l.view_phi_deg) +
                       " read alone is not the view of the whole dataset (two cameras within "
                       "0.5°?); fit in memory (raise --memory)");
    if (!all_mask.empty()) v->mask = all_mask;
    return v;
  };
  {  // Alpha masks: the AND over every view first (one more read of each view).
    auto front = read_view(frontal);
    if (!front.ok()) return front.status();
    if (front->mask_source.rfind("alpha", 0) == 0 ||
        front->mask_source.rfind("none: the alpha", 0) == 0) {
      std::vector<uint8_t> mask(size_t(shape.plane_size()), 1);
      for (int g = 0; g < V; ++g) {
        auto v = read_view(g);
        if (!v.ok()) return v.status();
        if (v->has_mask())
          for (size_t p = 0; p < mask.size(); ++p) mask[p] &= v->mask[p];
      }
      if (std::count(mask.begin(), mask.end(), uint8_t(1)) < int64_t(mask.size()))
        all_mask = std::move(mask);
    }
  }
  StreamedPerView out;
  FitResult& r = out.fit;
  r.method = method.name();
  r.frontal_view = frontal;
  r.views.resize(size_t(V));
  std::string tone_reason;
  ReconstructionSums recon, common;
  ViewThetaSums view_theta;
  LightStack decoded = shape;  // every view's decode records, for DescribeReadEncoding
  decoded.encodings.clear(), decoded.encoding_reasons.clear();
  int64_t done = 0;
  for (int g : order) {
    if (progress && !progress(done, steps)) return Status(StatusCode::kCancelled, "cancelled");
    auto view = read_view(g);
    if (!view.ok()) return view.status();
    if (g == frontal) {
      if (read.color_space == ColorSpaceChoice::kAuto) {
        StackDiagnostics diagnosis = DiagnoseStack(*view);
        out.tone = ResolveToneCurve(&*view, &diagnosis);
        if (out.tone->corrected && !view->encoding_reasons.empty())
          tone_reason = view->encoding_reasons[0];
      }
    } else if (out.tone && out.tone->corrected) {
      view->Relinearise(out.tone->to, tone_reason);
    }
    decoded.encodings.insert(decoded.encodings.end(), view->encodings.begin(),
                             view->encodings.end());
    decoded.encoding_reasons.insert(decoded.encoding_reasons.end(), view->encoding_reasons.begin(),
                                    view->encoding_reasons.end());
    FitOptions fo = o;  // view g's tiles as its share of the views
    fo.progress = [&](int64_t d, int64_t t) {
      return !progress || t <= 0 || progress(done * t + d, steps * t);
    };
    auto fit = base->Fit(*view, fo);
    if (!fit.ok()) {
      if (fit.status().code() == StatusCode::kCancelled) return fit.status();
      return Status(fit.status().code(),
                    method.name() + ": view " + std::to_string(view->view_theta_deg) + "," +
                        std::to_string(view->view_phi_deg) + ": " + fit.status().message());
    }
    AddScores(*view, fit->maps, fit->status, false, &recon);
    AddScores(*view, fit->maps, CommonTexelStatus(fit->status), false, &common);
    AddDeviationByViewTheta(*view, fit->maps, fit->status, &view_theta);
    for (const std::string& w : fit->warnings)
      if (std::find(r.warnings.begin(), r.warnings.end(), w) == r.warnings.end())
        r.warnings.push_back(w);
    if (g == frontal) {
      r.maps = fit->maps, r.status = fit->status;
      r.parameters = fit->parameters;
      r.flagged_texels = fit->flagged_texels;
      r.dropped_lights = fit->dropped_lights;
      r.refit_texels = fit->refit_texels, r.dropped_samples = fit->dropped_samples;
      // The pack's own maps are this view's: their bound, from its images.
      out.assessment = AssessFit(*view, *base, &r);
    }
    ViewFit& vf = r.views[size_t(g)];
    vf.theta_deg = view->view_theta_deg, vf.phi_deg = view->view_phi_deg;
    vf.view = view->view_direction;
    vf.maps = std::move(fit->maps), vf.status = std::move(fit->status);
    vf.parameters = std::move(fit->parameters);
    ++done;
  }
  r.parameters["views"] = V;
  out.read_encoding = DescribeReadEncoding(decoded);
  out.reconstruction = recon.Metrics();
  out.reconstruction_common = common.Metrics();
  out.deviation_by_view_theta = DeviationByViewTheta(view_theta);
  // Held-out views: read again and predicted by the nearest other view's maps — the per-view fit
  // without them is the one above restricted to the other views.
  if (!held.empty()) {
    // The training views' directions (the maps stay in r.views: no copy).
    FitResult train;
    std::vector<int> train_index;
    std::vector<char> out_view(size_t(V), 0);
    for (int h : held) out_view[size_t(h)] = 1;
    for (int g = 0; g < V; ++g)
      if (!out_view[size_t(g)]) {
        ViewFit direction;
        direction.view = r.views[size_t(g)].view;
        train.views.push_back(std::move(direction));
        train_index.push_back(g);
      }
    HeldOutViewMetrics hv;
    hv.train_views = V - int(held.size());
    ReconstructionSums all;
    for (int h : held) {
      if (progress && !progress(done, steps)) return Status(StatusCode::kCancelled, "cancelled");
      auto view = read_view(h);
      if (!view.ok()) return view.status();
      if (out.tone && out.tone->corrected) view->Relinearise(out.tone->to, tone_reason);
      const ViewFit& near =
          r.views[size_t(train_index[size_t(NearestViewFit(train, view->view_direction))])];
      ReconstructionSums one;
      AddScores(*view, near.maps, near.status, true, &one, &all);
      hv.views.push_back({view->view_theta_deg, view->view_phi_deg, one.Metrics()});
      ++done;
    }
    hv.all = all.Metrics();
    std::sort(hv.views.begin(), hv.views.end(), [](const HeldOutView& a, const HeldOutView& b) {
      return std::pair(a.theta_deg, a.phi_deg) < std::pair(b.theta_deg, b.phi_deg);
    });
    out.heldout_views = std::move(hv);
  }
  if (progress) progress(steps, steps);
  r.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace matfit::fit
