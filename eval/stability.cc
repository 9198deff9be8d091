#include "eval/stability.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/color.h"
#include "core/synth/light_sets.h"
#include "core/synth/micro_geometry.h"
#include "core/synth/perturb.h"
#include "core/synth/random.h"
#include "core/synth/synth.h"
#include "fit/assess.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "leaf/synthetic_leaf.h"
#include "leaf/translucency.h"

namespace matfit::eval {
namespace {

constexpr const char* kLeafMethod = "leaf-hl2";

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  const size_t k = std::min(v.size() - 1, size_t(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

struct CaseData {
  MaterialMaps truth;
  LightStack stack;
  // Micro-geometry cases: the surface whose renders are the relighting truth
  // (synth/micro_geometry.h).
  std::shared_ptr<const synth::MicroSurface> micro;
};

// Builds the perturbed stack of case `name` at size² texels.
StatusOr<CaseData> MakeCase(const std::string& name, int size) {
  std::string material = "plaster", lights = "bonn81";
  bool shadows = false;
  synth::PerturbOptions p;
  p.gaussian_sigma = 0.005;  // every case but "clean" has a good camera's read noise
  p.seed = 7;
  std::vector<LightSample> custom;
  if (name == "clean")
    p.gaussian_sigma = 0;
  else if (name == "noise-0.5%")
    p.gaussian_sigma = 0.005;
  else if (name == "noise-1%")
    p.gaussian_sigma = 0.01;
  else if (name == "noise-2%")
    p.gaussian_sigma = 0.02;
  else if (name == "noise-5%")
    p.gaussian_sigma = 0.05;
  else if (name == "shot-noise")
    p.gaussian_sigma = 0, p.shot_photons = 400;
  else if (name == "cast-shadows")
    material = "corduroy", shadows = true;
  else if (name == "highlights")
    material = "plastic";
  else if (name == "clip-0.9")
    material = "plastic", p.clip = 0.9;
  else if (name == "clip-0.8")
    material = "plastic", p.clip = 0.8;
  else if (name == "clipped-highlights")
    material = "lacquer", p.clip = 1.0;
  else if (name == "gamma-8bit") {
  } else if (name == "misregister-0.5px")
    material = "granite", p.misregister_px = 0.5;
  else if (name == "misregister-1px")
    material = "granite", p.misregister_px = 1.0;
  else if (name == "lights-3")
    lights = "dome:3";
  else if (name == "lights-4")
    lights = "dome:4";
  else if (name == "lights-6")
    lights = "dome:6";
  else if (name == "coplanar") {
    for (int i = 0; i < 12; ++i) {
      const double t = (-60.0 + 120.0 * i / 11) * M_PI / 180;
      custom.push_back(LightFromDirection(Vec3(std::sin(t), 0, std::cos(t))));
    }
  } else if (name == "grazing-only")
    lights = "ring:12:75";
  else if (name == "nan-pixels") {
  } else if (name == "leaf")
    material = "leaf";
  else if (name == "micro-geometry")
    material = "micro-stone";
  else
    return InvalidArgument("unknown stability case '" + name + "'");
  if (custom.empty()) {
    auto set = synth::MakeLightSet(lights, 3);
    if (!set.ok()) return set.status();
    custom = std::move(*set);
  }
  auto rendered = synth::RenderMaterial(material, size, size, 3, custom, shadows);
  if (!rendered.ok()) return rendered.status();
  CaseData d;
  d.truth = std::move(rendered->truth);
  d.stack = std::move(rendered->stack);
  d.micro = std::move(rendered->micro_surface);
  synth::ApplyPerturbations(p, &d.stack);
  float* v = d.stack.data();
  const int64_t n = int64_t(d.stack.num_images()) * d.stack.channels() * d.stack.plane_size();
  if (name == "gamma-8bit")  // 8-bit sRGB files read as linear: the classic gamma mistake
    for (int64_t i = 0; i < n; ++i) v[i] = LinearToSrgb8(std::clamp(v[i], 0.0f, 1.0f)) / 255.0f;
  if (name == "clipped-highlights") {
    // As an integer file records them: the saturated samples at the maximum code, which the
    // reader counts per image (LightStack::saturated_pixels), so the fits know they clipped.
    d.stack.saturated_pixels.assign(size_t(d.stack.num_images()), 0);
    for (int i = 0; i < d.stack.num_images(); ++i)
      for (int c = 0; c < d.stack.channels(); ++c)
        for (const float x : d.stack.Plane(i, c)) d.stack.saturated_pixels[size_t(i)] += x >= 1.0f;
  }
  if (name == "nan-pixels")  // 1 % of the samples lost (dead pixels, failed decode)
    for (int64_t i = 0; i < n; ++i)
      if (synth::HashUniform(11, uint64_t(i)) < 0.01) v[i] = NAN;
  return d;
}

void ScoreFit(const std::string& method_name, const CaseData& d, StabilityCell* cell) {
  auto method = fit::MakeMethod(method_name);
  auto fit = method->Fit(d.stack, {});
  if (!fit.ok()) {
    cell->refused = true;
    cell->error = fit.status().message();
    return;
  }
  const std::vector<uint8_t> fitted = fit->status;
  const auto a = fit::AssessFit(d.stack, *method, &*fit);
  cell->warnings = int(fit->warnings.size());
  // Scored over the directions the bound claims (fit/confidence.h: the supported cone).
  const std::vector<Vec3> dome =
      fit::DomeDirections(48, a.confidence.supported_theta_deg, a.confidence.supported_axis);
  std::vector<float> err;
  if (d.micro) {  // its appearance is the micro-geometry's, not its maps'
    std::vector<LightSample> lights;
    for (const Vec3& l : dome) lights.push_back(LightFromDirection(l));
    err = fit::RelightingError(fit->maps, synth::RenderMicroStack(*d.micro, lights));
  } else {
    err = fit::RelightingError(fit->maps, d.truth, dome, d.stack.view_direction,
                               a.confidence.recorded_limit);
  }
  std::vector<double> errs, bounds, angles;
  int64_t flagged = 0;
  const bool has_normal = fit::CompareToTruth(fit->maps, d.truth, {}).has_normal;
  for (size_t p = 0; p < err.size(); ++p) {
    if (!d.truth.mask.empty() && d.truth.mask.data()[p] < 0.5f) continue;  // background
    ++cell->texels;
    if (fit->status[p] != fit::kTexelOk) {
      ++flagged;
      continue;
    }
    // An ok texel whose maps do not even evaluate to a number has failed silently.
    const double e = std::isfinite(err[p]) ? err[p] : INFINITY;
    errs.push_back(e);
    bounds.push_back(a.confidence.bound[p]);
    cell->silent += e > a.confidence.bound[p];
    if (has_normal) {
      const Vec3 nf(fit->maps.normal.Plane(0)[p], fit->maps.normal.Plane(1)[p],
                    fit->maps.normal.Plane(2)[p]);
      const Vec3 nt(d.truth.normal.Plane(0)[p], d.truth.normal.Plane(1)[p],
                    d.truth.normal.Plane(2)[p]);
      angles.push_back(AngleBetweenDeg(nf, nt));
    }
  }
  cell->error_median = Quantile(errs, 0.5);
  cell->error_p95 = Quantile(errs, 0.95);
  cell->bound_median = Quantile(bounds, 0.5);
  const fit::BoundRatio ratio = fit::BoundToActualRatio(a.confidence.bound, err, fit->status);
  cell->bound_ratio_median = ratio.median, cell->bound_ratio_p90 = ratio.p90;
  if (!angles.empty()) {
    double s = 0;
    for (double x : angles) s += x;
    cell->normal_mae_deg = s / angles.size();
  }
  cell->flagged_fraction = cell->texels ? double(flagged) / cell->texels : 0;
  cell->silent_fraction = cell->texels ? double(cell->silent) / cell->texels : 0;
}

// The leaf HL2 precompute: the fast method against the published direct one (response R per
// texel, relative error), bounded by the fast method's declared kernel tolerance; thin texels
// (below the multipole model's validity) are its flags.
void ScoreLeaf(const std::string& name, int size, StabilityCell* cell) {
  leaf::SyntheticLeaf s;
  leaf::MakeSyntheticLeaf(std::min(size, 32), 0.1, 1.0, &s);
  if (name == "thin-leaf")
    for (float& t : s.thickness.data()) t *= 0.15f;  // 0.03–0.075 mm
  leaf::TranslucencyOptions o;
  o.directions = 32;
  auto fast = leaf::PrecomputeTranslucencyFast(s.input, o);
  auto ref = leaf::PrecomputeTranslucencyReference(s.input, o);
  if (!fast.ok() || !ref.ok()) {
    cell->refused = true;
    cell->error = !fast.ok() ? fast.status().message() : ref.status().message();
    return;
  }
  const double bound = std::max(fast->kernel_error, o.kernel_tolerance);
  cell->warnings = int(fast->warnings.size());
  std::vector<double> errs, ratios;
  int64_t flagged = 0;
  for (size_t p = 0; p < s.mask.size(); ++p) {
    if (!s.mask[p]) continue;
    ++cell->texels;
    if (!fast->thin.empty() && fast->thin[p]) {
      ++flagged;
      continue;
    }
    const double r = ref->response.data()[p];
    if (!(r > 0)) continue;
    const double e = std::abs(fast->response.data()[p] - r) / r;
    errs.push_back(e);
    if (e > 0) ratios.push_back(bound / e);
    cell->silent += e > bound;
  }
  cell->bound_ratio_median = Quantile(ratios, 0.5), cell->bound_ratio_p90 = Quantile(ratios, 0.9);
  cell->error_median = Quantile(errs, 0.5);
  cell->error_p95 = Quantile(errs, 0.95);
  cell->bound_median = bound;
  cell->flagged_fraction = cell->texels ? double(flagged) / cell->texels : 0;
  cell->silent_fraction = cell->texels ? double(cell->silent) / cell->texels : 0;
}

}  // namespace

const std::vector<StabilityCase>& StabilityCases() {
  static const std::vector<StabilityCase> cases = {
      {"clean", "plaster, bonn81, no noise", false},
      {"noise-0.5%", "Gaussian read noise σ = 0.5 % of full scale", false},
      {"noise-1%", "σ = 1 %", false},
      {"noise-2%", "σ = 2 %", false},
      {"noise-5%", "σ = 5 %", false},
      {"shot-noise", "Poisson, 400 photons at full scale", false},
      {"cast-shadows", "corduroy with cast shadows from its height field", false},
      {"highlights", "glossy plastic (Blinn–Phong e 40)", false},
      {"clip-0.9", "plastic clipped at 0.9 of full scale", true},
      {"clip-0.8", "plastic clipped at 0.8", true},
      {"clipped-highlights",
       "lacquer (GGX, roughness 0.2–0.5) whose peaks saturate, marked as an integer file's "
       "maximum code: the bound covers the recorded range",
       true},
      {"gamma-8bit", "8-bit sRGB values read as linear (the gamma mistake)", true},
      {"misregister-0.5px", "granite, images shifted by up to 0.5 px", false},
      {"misregister-1px", "granite, shifted by up to 1 px", false},
      {"lights-3", "3 lights (dome)", true},
      {"lights-4", "4 lights", true},
      {"lights-6", "6 lights", true},
      {"coplanar", "12 lights on one great circle (φ = 0°/180°)", true},
      {"grazing-only", "12 lights at θ = 75°", true},
      {"nan-pixels", "1 % of the samples NaN", true},
      {"leaf", "synthetic leaf on a dark background (mask)", false},
      {"micro-geometry",
       "stone rendered from sub-texel micro-geometry (shadowing, masking, one bounce): no "
       "fitted model's formula",
       false},
      {"thin-leaf", "leaf thickness × 0.15 (0.03–0.075 mm): translucency precompute", true},
  };
  return cases;
}

bool StabilityOptions::Check(std::string* why) const {
  if (size < 8 || size > 256) {
    *why = "stability size must be in [8, 256], got " + std::to_string(size);
    return false;
  }
  for (const auto& m : methods)
    if (m != kLeafMethod && !fit::MakeMethod(m)) {
      *why = "'" + m + "' is not a method (see matfit fit --model list, or leaf-hl2)";
      return false;
    }
  for (const auto& c : cases)
    if (std::none_of(StabilityCases().begin(), StabilityCases().end(),
                     [&](const StabilityCase& k) { return k.name == c; })) {
      *why = "'" + c + "' is not a stability case";
      return false;
    }
  return true;
}

StatusOr<StabilityResult> RunStability(const StabilityOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  StabilityResult r;
  r.size = o.size;
  r.methods = o.methods;
  if (r.methods.empty()) {
    r.methods = fit::MethodNames();
    r.methods.push_back(kLeafMethod);
  }
  if (o.cases.empty())
    for (const auto& c : StabilityCases()) r.perturbations.push_back(c.name);
  else
    r.perturbations = o.cases;
  const int64_t total = int64_t(r.methods.size() * r.perturbations.size());
  int64_t done = 0;
  r.cells.resize(size_t(total));
  for (size_t j = 0; j < r.perturbations.size(); ++j) {
    const std::string& c = r.perturbations[j];
    StatusOr<CaseData> data = Status(StatusCode::kInternal, "not made");
    if (c != "thin-leaf") data = MakeCase(c, o.size);
    for (size_t i = 0; i < r.methods.size(); ++i) {
      StabilityCell& cell = r.cells[i * r.perturbations.size() + j];
      cell.method = r.methods[i];
      cell.perturbation = c;
      const bool leaf_method = cell.method == kLeafMethod;
      cell.applicable = leaf_method ? (c == "leaf" || c == "thin-leaf") : c != "thin-leaf";
      if (cell.applicable) {
        if (leaf_method)
          ScoreLeaf(c, o.size, &cell);
        else if (!data.ok())
          return data.status();
        else
          ScoreFit(cell.method, *data, &cell);
      }
      if (o.progress && !o.progress(++done, total))
        return Status(StatusCode::kCancelled, "cancelled");
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string StabilityJson(const StabilityResult& r) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(); };
  json cells = json::array(), cases = json::array();
  for (const auto& c : StabilityCases())
    if (std::find(r.perturbations.begin(), r.perturbations.end(), c.name) != r.perturbations.end())
      cases.push_back(
          {{"name", c.name}, {"description", c.description}, {"degenerate", c.degenerate}});
  for (const auto& c : r.cells)
    cells.push_back({{"method", c.method},
                     {"perturbation", c.perturbation},
                     {"applicable", c.applicable},
                     {"refused", c.refused},
                     {"error", c.refused ? json(c.error) : json()},
                     {"texels", c.texels},
                     {"error_median", num(c.error_median)},
                     {"error_p95", num(c.error_p95)},
                     {"normal_mae_deg", num(c.normal_mae_deg)},
                     {"flagged_fraction", c.flagged_fraction},
                     {"warnings", c.warnings},
                     {"silent_texels", c.silent},
                     {"silent_fraction", c.silent_fraction},
                     {"bound_median", num(c.bound_median)},
                     {"bound_ratio_median", num(c.bound_ratio_median)},
                     {"bound_ratio_p90", num(c.bound_ratio_p90)}});
  json j = {{"schema", "matfit.stability/1"}, {"size", r.size}, {"methods", r.methods},
            {"perturbations", cases},         {"cells", cells}, {"seconds", r.seconds}};
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace matfit::eval
