#include "eval/bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/dataset/dataset.h"
#include "core/parallel.h"
#include "core/shading/evaluate.h"
#include "core/stack_ops.h"
#include "core/synth/micro_geometry.h"
#include "core/synth/synth.h"
#include "fit/assess.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "leaf/hl2_error.h"
#include "leaf/scan.h"
#include "leaf/sheet.h"
#include "leaf/synthetic_leaf.h"

namespace matfit::eval {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Loaded {
  LightStack stack;
  std::optional<MaterialMaps> truth;
  // Micro-geometry materials: the relighting truth over the 48-direction dome, rendered from the
  // micro-geometry (their truth maps are normal and albedo only).
  std::optional<LightStack> truth_dome;
};

// The dome the synthetic cases' relighting error is taken over.
std::vector<Vec3> RelightDome() { return fit::DomeDirections(48, 75); }

StatusOr<Loaded> LoadCase(const BenchCase& c) {
  Loaded l;
  if (!c.material.empty()) {
    synth::SynthOptions o;
    o.material = c.material;
    o.lights = c.lights;
    o.size = c.size;
    o.layout = Layout::kLp;
    o.bits = 32;
    o.perturb.gaussian_sigma = 0.005;  // a good camera: 0.5 % read noise
    auto r = synth::Synthesize(o);
    if (!r.ok()) return r.status();
    l.stack = std::move(r->stack);
    l.truth = std::move(r->truth);
    if (r->micro_surface) {
      std::vector<LightSample> dome;
      for (const Vec3& d : RelightDome()) dome.push_back(LightFromDirection(d));
      l.truth_dome = synth::RenderMicroStack(*r->micro_surface, dome);
    }
    return l;
  }
  StatusOr<LightStack> s = Status(StatusCode::kInternal, "not read");
  if (c.leaf_sheet) {
    auto scan = leaf::ReadLeafScan(c.path);
    if (!scan.ok()) return scan.status();
    auto sheet = leaf::AnalyzeSheet(&*scan, leaf::SheetOptions{});
    if (!sheet.ok()) return sheet.status();
    // Only the leaves: not the twigs, markers, specks or the bare sheet.
    int max_label = 0;
    for (const auto& comp : sheet->segmentation.components)
      max_label = std::max(max_label, comp.label);
    std::vector<uint8_t> leaf_label(size_t(max_label) + 1, 0);
    for (const auto& comp : sheet->segmentation.components)
      if (comp.kind == leaf::ComponentKind::kLeaf) leaf_label[size_t(comp.label)] = 1;
    LightStack top = std::move(sheet->top);
    top.mask.assign(size_t(top.plane_size()), 0);
    for (size_t p = 0; p < top.mask.size(); ++p) {
      const int32_t lab = sheet->segmentation.labels[p];
      top.mask[p] = lab > 0 && lab <= max_label ? leaf_label[size_t(lab)] : 0;
    }
    s = std::move(top);
  } else {
    s = ReadDataset(c.path);
    // Read as `matfit fit` reads it (--color-space auto acts on the tone-curve estimate).
    if (s.ok()) {
      fit::StackDiagnostics d = fit::DiagnoseStack(*s);
      (void)fit::ResolveToneCurve(&*s, &d);
    }
  }
  if (!s.ok()) return s.status();
  int x, y, w, h;
  MaskBounds(*s, 2, &x, &y, &w, &h);
  auto crop = CropStack(*s, x, y, w, h);
  if (!crop.ok()) return crop.status();
  auto small = DownsampleStack(*crop, c.downsample);
  if (!small.ok()) return small.status();
  l.stack = std::move(*small);
  return l;
}

// Leave-one-out costs one fit per image: real cases only, and sets of at most this many images.
constexpr int kMaxLooImages = 64;

BenchPoint RunPoint(const fit::FitMethod& method, const std::string& dataset, const Loaded& data,
                    const BenchOptions& o, int repeats) {
  BenchPoint pt;
  pt.method = method.name();
  pt.dataset = dataset;
  pt.texels = data.stack.MaskedTexels();
  pt.images = data.stack.num_images();
  pt.parameters = method.parameters_per_texel();
  pt.bytes_per_texel = method.bytes_per_texel();
  std::vector<double> times;
  StatusOr<fit::FitResult> fit = Status(StatusCode::kInternal, "not run");
  for (int r = 0; r < repeats; ++r) {
    fit = method.Fit(data.stack, {});
    if (!fit.ok()) break;
    times.push_back(fit->fit_seconds);
  }
  if (!fit.ok()) {
    pt.ok = false;
    pt.error = fit.status().message();
    return pt;
  }
  pt.fit_seconds = Median(times);
  pt.texels_per_second = pt.texels / std::max(1e-9, pt.fit_seconds);
  const std::vector<uint8_t> fitted = fit->status;
  const auto rec = fit::Reconstruction(data.stack, fit->maps, fitted);
  pt.deviation_percent = rec.deviation_percent;
  pt.deviation_percent_by_theta = rec.deviation_percent_by_theta;
  const auto a = fit::AssessFit(data.stack, method, &*fit);
  pt.flagged_texels = fit->flagged_texels;
  std::vector<double> bounds;
  for (float b : a.confidence.bound)
    if (std::isfinite(b)) bounds.push_back(b);
  pt.bound_median = Median(bounds);
  pt.render_ns_per_pixel = fit::ShadingCostNs(fit->maps);
  // --quick scores synthetic cases by their truth only (held-out lights cost k more fits).
  if (o.holdout >= 2 && !(o.quick && data.truth)) {
    auto h = fit::HeldOut(method, data.stack, o.holdout, {});
    if (h.ok())
      pt.heldout_rmse = h->rmse_common, pt.heldout_rmse_fitted = h->rmse,
      pt.heldout_deviation_percent = h->deviation_percent,
      pt.heldout_psnr_srgb8_db = h->psnr_srgb8_db_common;
  }
  if (o.loo && !data.truth && data.stack.num_images() <= kMaxLooImages) {
    auto h = fit::HeldOut(method, data.stack, fit::kLeaveOneOut, {});
    if (h.ok()) {
      pt.loo_rmse = h->rmse_common, pt.loo_psnr_db = h->psnr_db_common;
      pt.loo_psnr_srgb8_db = h->psnr_srgb8_db_common;
      const fit::BoundRatio ratio =
          fit::BoundToActualRatio(a.confidence.bound, h->texel_rmse, fit->status);
      pt.loo_bound_ratio_median = ratio.median, pt.loo_bound_ratio_p90 = ratio.p90;
      pt.loo_bound_exceeded_fraction = ratio.exceeded_fraction;
    }
  }
  if (data.truth) {
    const auto t = fit::CompareToTruth(fit->maps, *data.truth, fitted);
    if (t.has_normal) pt.normal_mae_deg = t.normal_mae_deg;
    if (t.has_albedo) pt.albedo_rmse = t.albedo_rmse;
    const auto err = data.truth_dome ? fit::RelightingError(fit->maps, *data.truth_dome)
                                     : fit::RelightingError(fit->maps, *data.truth, RelightDome(),
                                                            data.stack.view_direction);
    double s2 = 0;
    int64_t k = 0;
    for (size_t p = 0; p < err.size(); ++p)
      if (fitted[p] == fit::kTexelOk && std::isfinite(err[p])) s2 += double(err[p]) * err[p], ++k;
    if (k) pt.relight_rmse = std::sqrt(s2 / k);
  }
  return pt;
}

std::vector<Hl2Point> RunHl2(bool quick, std::string* leaf_name) {
  leaf::SyntheticLeaf s;
  const int size = quick ? 48 : 96;
  leaf::MakeSyntheticLeaf(size, 0.1, 4.0, &s);
  *leaf_name = "synthetic leaf " + std::to_string(size) + "², 0.1 mm/texel, 4× relief";
  std::vector<Hl2Point> out;
  const std::vector<int> counts = quick ? std::vector<int>{8, 32, 128, 512}
                                        : std::vector<int>{8, 16, 32, 64, 128, 256, 512, 1024};
  const std::vector<double> elevations = {M_PI / 2, M_PI / 4, M_PI / 8};
  {  // warm-up: the first call pays one-time set-up (kernel tables, FFT plans)
    leaf::TranslucencyOptions o;
    (void)leaf::PrecomputeTranslucencyFast(s.input, o);
  }
  for (int n : counts) {
    leaf::TranslucencyOptions o;
    o.directions = n;
    const auto t0 = Clock::now();
    auto r = leaf::PrecomputeTranslucencyFast(s.input, o);
    if (!r.ok()) continue;
    Hl2Point p;
    p.directions = n;
    p.precompute_seconds = Since(t0);
    auto e = leaf::Hl2ReconstructionErrors(s.input, o, *r, elevations, quick ? 400 : 1500);
    if (!e.ok()) continue;
    for (const auto& st : *e) {
      p.error_percent_by_elevation.push_back(100 * st.mean);
      p.mean_error_percent += 100 * st.mean / e->size();
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace

bool BenchOptions::Check(std::string* why) const {
  if (repeats < 0 || repeats > 50) {
    *why = "--repeats must be in [0, 50], got " + std::to_string(repeats);
    return false;
  }
  if (holdout == 1 || holdout < 0) {
    *why = "--holdout must be 0 (off) or ≥ 2 folds, got " + std::to_string(holdout);
    return false;
  }
  const std::vector<BenchCase> all = DefaultSuite(quick);
  const std::vector<MultiViewCase> views = MultiViewSuite(quick);
  for (const auto& c : cases)
    if (std::none_of(all.begin(), all.end(), [&](const BenchCase& b) { return b.name == c; }) &&
        std::none_of(views.begin(), views.end(),
                     [&](const MultiViewCase& b) { return b.name == c; })) {
      *why = "--cases: '" + c + "' is not a case of the" + (quick ? " --quick" : "") +
             " suite (e.g. psm-gray, psm-cat, leaf-sheet, plastic-64, " + views[0].name + ")";
      return false;
    }
  for (const auto& m : methods)
    if (!fit::MakeMethod(m)) {
      *why = "--methods: '" + m + "' is not a method (see matfit fit --model list)";
      return false;
    }
  return true;
}

std::vector<BenchCase> DefaultSuite(bool quick) {
  std::vector<BenchCase> s;
  const std::vector<int> sizes = quick ? std::vector<int>{40} : std::vector<int>{64, 128, 256};
  for (const char* m : {"plaster", "plastic", "wool", "corduroy", "granite", "leaf", "micro-stone"})
    for (int n : sizes) s.push_back({std::string(m) + "-" + std::to_string(n), m, "bonn81", n});
  for (const char* r : {"gray", "cat"}) {
    BenchCase c;
    c.name = std::string("psm-") + r;
    c.path = std::string("psm/") + r;
    c.downsample = quick ? 5 : 1;
    s.push_back(c);
  }
  BenchCase sheet;
  sheet.name = "leaf-sheet";
  sheet.path = "leaf-sheet";
  sheet.leaf_sheet = true;
  sheet.downsample = quick ? 4 : 1;
  s.push_back(sheet);
  return s;
}

StatusOr<BenchResult> RunBench(const BenchOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = Clock::now();
  BenchResult res;
  res.holdout = o.holdout;
  res.loo = o.loo;
  res.threads = NumThreads();
  const std::vector<std::string> methods = o.methods.empty() ? fit::MethodNames() : o.methods;
  const int repeats = o.repeats ? o.repeats : (o.quick ? 1 : 3);
  std::vector<BenchCase> suite;
  for (const BenchCase& c : DefaultSuite(o.quick))
    if (o.cases.empty() || std::find(o.cases.begin(), o.cases.end(), c.name) != o.cases.end())
      suite.push_back(c);
  std::vector<MultiViewCase> view_cases;
  for (const MultiViewCase& c : MultiViewSuite(o.quick))
    if (o.multi_view && ((o.cases.empty() && o.methods.empty()) ||
                         std::find(o.cases.begin(), o.cases.end(), c.name) != o.cases.end()))
      view_cases.push_back(c);
  const MultiViewMethods view_methods;
  const int64_t per_view_case = int64_t(view_methods.joint.size() + view_methods.per_view.size() +
                                        view_methods.frontal.size() + 1);
  const int64_t total =
      int64_t(suite.size() * methods.size()) + int64_t(view_cases.size()) * per_view_case + 1;
  int64_t done = 0;
  for (BenchCase c : suite) {
    if (!c.path.empty()) {
      const std::string full = (std::filesystem::path(o.shared_data) / c.path).string();
      if (o.shared_data.empty() || !std::filesystem::exists(full)) {
        res.skipped.push_back(
            c.name + ": " +
            (o.shared_data.empty() ? "no shared data folder" : full + " is absent"));
        done += int64_t(methods.size());
        continue;
      }
      c.path = full;
    }
    auto data = LoadCase(c);
    if (!data.ok()) {
      res.skipped.push_back(c.name + ": " + data.status().message());
      done += int64_t(methods.size());
      continue;
    }
    c.size = data->stack.width();
    res.cases.push_back(c);
    for (const auto& m : methods) {
      res.points.push_back(RunPoint(*fit::MakeMethod(m), c.name, *data, o, repeats));
      if (o.progress && !o.progress(++done, total))
        return Status(StatusCode::kCancelled, "cancelled");
    }
  }
  for (const MultiViewCase& c : view_cases) {
    const int64_t base = done;
    auto pts = RunMultiViewCase(c, view_methods, repeats, [&](int64_t d, int64_t) {
      return !o.progress || o.progress(base + d, total);
    });
    if (!pts.ok()) {
      if (pts.status().code() == StatusCode::kCancelled) return pts.status();
      res.skipped.push_back(c.name + ": " + pts.status().message());
    } else {
      for (auto& p : *pts) res.multi_view.push_back(std::move(p));
    }
    done = base + per_view_case;
  }
  res.hl2 = RunHl2(o.quick, &res.hl2_leaf);
  if (o.progress) o.progress(total, total);
  res.seconds = Since(t0);
  return res;
}

std::string BenchJson(const BenchResult& r) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(); };
  auto opt = [&](const std::optional<double>& v) { return v ? num(*v) : json(); };
  json cases = json::array(), points = json::array(), hl2 = json::array();
  for (const auto& c : r.cases)
    cases.push_back({{"name", c.name},
                     {"kind", c.material.empty() ? "real" : "synthetic"},
                     {"material", c.material.empty() ? json() : json(c.material)},
                     {"lights", c.material.empty() ? json() : json(c.lights)},
                     {"path", c.path.empty() ? json() : json(c.path)},
                     {"size", c.size},
                     {"downsample", c.downsample},
                     {"leaf_sheet", c.leaf_sheet}});
  for (const auto& p : r.points) {
    json by = json::object();
    for (const auto& [t, d] : p.deviation_percent_by_theta) by[std::to_string(t)] = d;
    points.push_back({{"method", p.method},
                      {"dataset", p.dataset},
                      {"ok", p.ok},
                      {"error", p.ok ? json() : json(p.error)},
                      {"texels", p.texels},
                      {"images", p.images},
                      {"parameters", p.parameters},
                      {"bytes_per_texel", p.bytes_per_texel},
                      {"fit_seconds", num(p.fit_seconds)},
                      {"texels_per_second", num(p.texels_per_second)},
                      {"render_ns_per_pixel", num(p.render_ns_per_pixel)},
                      {"deviation_percent", num(p.deviation_percent)},
                      {"deviation_percent_by_theta", by},
                      {"heldout_rmse", num(p.heldout_rmse)},
                      {"heldout_rmse_fitted_texels", num(p.heldout_rmse_fitted)},
                      {"heldout_deviation_percent", num(p.heldout_deviation_percent)},
                      {"heldout_psnr_srgb8_db", num(p.heldout_psnr_srgb8_db)},
                      {"loo_rmse", num(p.loo_rmse)},
                      {"loo_psnr_db", num(p.loo_psnr_db)},
                      {"loo_psnr_srgb8_db", num(p.loo_psnr_srgb8_db)},
                      {"loo_bound_ratio_median", num(p.loo_bound_ratio_median)},
                      {"loo_bound_ratio_p90", num(p.loo_bound_ratio_p90)},
                      {"loo_bound_exceeded_fraction", num(p.loo_bound_exceeded_fraction)},
                      {"normal_mae_deg", opt(p.normal_mae_deg)},
                      {"albedo_rmse", opt(p.albedo_rmse)},
                      {"relight_rmse", opt(p.relight_rmse)},
                      {"flagged_texels", p.flagged_texels},
                      {"bound_median", num(p.bound_median)}});
  }
  json views = json::array();
  for (const auto& p : r.multi_view) {
    json by_view = json::object();
    for (const auto& [tv, e] : p.heldout_view_rmse_by_theta) by_view[std::to_string(tv)] = num(e);
    views.push_back({{"dataset", p.dataset},
                     {"method", p.method},
                     {"family", p.family},
                     {"k", p.family == "pca" ? json(p.k) : json()},
                     {"ok", p.ok},
                     {"error", p.ok ? json() : json(p.error)},
                     {"bytes_per_texel", num(p.bytes_per_texel)},
                     {"heldout_view_rmse", num(p.heldout_view_rmse)},
                     {"heldout_view_texel_rms", num(p.heldout_view_texel_rms)},
                     {"heldout_view_rmse_by_theta", by_view},
                     {"fit_seconds", num(p.fit_seconds)},
                     {"texels_per_second", num(p.texels_per_second)},
                     {"normal_mae_deg", opt(p.normal_mae_deg)}});
  }
  for (const auto& h : r.hl2)
    hl2.push_back({{"directions", h.directions},
                   {"mean_error_percent", h.mean_error_percent},
                   {"error_percent_by_elevation", h.error_percent_by_elevation},
                   {"precompute_seconds", h.precompute_seconds}});
  json j = {{"schema", "matfit.bench/1"},
            {"cases", cases},
            {"skipped", r.skipped},
            {"points", points},
            {"multi_view", views},
            {"hl2_leaf", r.hl2_leaf},
            {"hl2", hl2},
            {"holdout", r.holdout},
            {"loo", r.loo},
            {"threads", r.threads},
            {"seconds", r.seconds}};
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace matfit::eval
