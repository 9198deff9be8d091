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
#include "core/synth/synth.h"
#include "fit/assess.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "leaf/hl2_error.h"
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
};

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
    return l;
  }
  auto s = ReadDataset(c.path);
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
      pt.heldout_deviation_percent = h->deviation_percent;
  }
  if (data.truth) {
    const auto t = fit::CompareToTruth(fit->maps, *data.truth, fitted);
    if (t.has_normal) pt.normal_mae_deg = t.normal_mae_deg;
    if (t.has_albedo) pt.albedo_rmse = t.albedo_rmse;
    const auto err = fit::RelightingError(fit->maps, *data.truth, fit::DomeDirections(48, 75),
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
  for (const char* m : {"plaster", "plastic", "wool", "corduroy", "granite", "leaf"})
    for (int n : sizes) s.push_back({std::string(m) + "-" + std::to_string(n), m, "bonn81", n});
  for (const char* r : {"gray", "cat"}) {
    BenchCase c;
    c.name = std::string("psm-") + r;
    c.path = std::string("psm/") + r;
    c.downsample = quick ? 5 : 1;
    s.push_back(c);
  }
  return s;
}

StatusOr<BenchResult> RunBench(const BenchOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = Clock::now();
  BenchResult res;
  res.holdout = o.holdout;
  res.threads = NumThreads();
  const std::vector<std::string> methods = o.methods.empty() ? fit::MethodNames() : o.methods;
  const int repeats = o.repeats ? o.repeats : (o.quick ? 1 : 3);
  std::vector<BenchCase> suite = DefaultSuite(o.quick);
  const int64_t total = int64_t(suite.size() * methods.size()) + 1;
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
                     {"downsample", c.downsample}});
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
                      {"normal_mae_deg", opt(p.normal_mae_deg)},
                      {"albedo_rmse", opt(p.albedo_rmse)},
                      {"relight_rmse", opt(p.relight_rmse)},
                      {"flagged_texels", p.flagged_texels},
                      {"bound_median", num(p.bound_median)}});
  }
  for (const auto& h : r.hl2)
    hl2.push_back({{"directions", h.directions},
                   {"mean_error_percent", h.mean_error_percent},
                   {"error_percent_by_elevation", h.error_percent_by_elevation},
                   {"precompute_seconds", h.precompute_seconds}});
  json j = {{"schema", "matfit.bench/1"}, {"cases", cases},         {"skipped", r.skipped},
            {"points", points},           {"hl2_leaf", r.hl2_leaf}, {"hl2", hl2},
            {"holdout", r.holdout},       {"threads", r.threads},   {"seconds", r.seconds}};
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace matfit::eval
