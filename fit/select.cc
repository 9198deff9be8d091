#include "fit/select.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/color.h"
#include "core/model/model.h"
#include "core/near_lights.h"
#include "core/stack_band.h"
#include "core/stack_ops.h"
#include "core/warnings.h"
#include "fit/assess.h"
#include "fit/diagnostics.h"
#include "fit/fit_common.h"
#include "fit/light_cover.h"
#include "fit/method.h"
#include "fit/metrics.h"

namespace matfit::fit {
namespace {

using nlohmann::json;

// Held-out accumulators of one candidate over all folds.
struct HeldOutSums {
  std::vector<double> sse;      // per image: Σ (pred − meas)² over ok texels × channels
  std::vector<int64_t> count;   // per image: samples
  std::vector<double> env_err;  // per texel × channel: Σ_i w_i (pred − meas), w_i = max(0, l_z)
  std::vector<double> env_w;    // per texel × channel: Σ_i w_i over the images it was scored on
  // sRGB metric, environment light: Σ_i w_i pred and Σ_i w_i meas apart (the codes of the
  // averages are compared, not averaged code differences).
  std::vector<double> env_pred, env_meas;
  int64_t flagged = 0, scored = 0;
  double fit_seconds = 0;
  MaterialMaps last_maps;
  int failed_folds = 0;
  std::string fold_error;  // the first failed fold's message
  bool any = false;
};

// Near lights: fine row y's texels as the coarse texels (level k) that predict them and their
// positions, for NearLightEvaluator.
struct NearRow {
  std::vector<int64_t> texels;
  std::vector<Vec3> points;
  std::vector<float> pred;
  void Set(const LightStack& fine, int y, int k, int CW, int cy) {
    const int W = fine.width();
    texels.resize(size_t(W)), points.resize(size_t(W)), pred.resize(size_t(3) * W);
    for (int x = 0; x < W; ++x) {
      texels[size_t(x)] = int64_t(cy) * CW + std::min(CW - 1, x >> k);
      points[size_t(x)] = NearTexelPosition(fine, x, y);
    }
  }
};

// Folds over images (image i in fold i mod K). `coarse` is the level-(L+k) stack, `fine` the
// level-L one; texel (x, y) of fine is predicted by texel (x >> k, y >> k) of coarse. Each
// fold's fit is assessed like a shipped fit (fit/assess.h): texels it cannot bound count as
// flagged. Fine texels whose coarse parent lies outside the (coarser) mask are not scored.
StatusOr<HeldOutSums> Score(const FitMethod& m, const LightStack& fine, const LightStack& coarse,
                            int k, int folds, const FitOptions& options, bool environment,
                            bool srgb8) {
  const int n = fine.num_images(), C = fine.channels();
  const int64_t T = fine.plane_size();
  HeldOutSums h;
  h.sse.assign(size_t(n), 0), h.count.assign(size_t(n), 0);
  if (environment) h.env_err.assign(size_t(T) * C, 0), h.env_w.assign(size_t(T) * C, 0);
  if (environment && srgb8)
    h.env_pred.assign(size_t(T) * C, 0), h.env_meas.assign(size_t(T) * C, 0);
  const std::vector<float> inv = InverseIntensities(fine);
  const bool clip = StackMayBeClipped(fine);
  const Vec3f v(fine.view_direction);
  for (int f = 0; f < folds; ++f) {
    std::vector<int> train, test;
    for (int i = 0; i < n; ++i) (i % folds == f ? test : train).push_back(i);
    const LightStack train_stack = BorrowImages(coarse, train);
    auto fit = m.Fit(train_stack, options);
    if (!fit.ok()) {
      if (fit.status().code() == StatusCode::kCancelled) return fit.status();
      if (h.failed_folds++ == 0) h.fold_error = fit.status().message();
      continue;
    }
    (void)AssessFit(train_stack, m, &*fit);
    if (f == 0) h.fit_seconds = fit->fit_seconds;
    h.any = true;
    // Batched: every test light's prediction of one coarse row, then the fine rows under it.
    std::vector<Vec3f> test_dirs, test_views;  // each image at its own view (multi-view)
    for (int i : test) test_dirs.emplace_back(fine.lights()[i].direction);
    for (int i : test) test_views.emplace_back(fine.ViewOf(i));
    const BatchEvaluator eval(fit->maps, test_dirs, test_views);
    const int W = fine.width(), CW = coarse.width(), CH = coarse.height();
    // Near lights: each fine texel under its own light (the coarse texel's maps).
    const bool near = fine.has_light_positions();
    NearRow nr;
    NearLightEvaluator near_eval(fit->maps, v);
    std::vector<float> pred(test.size() * size_t(C) * CW), scratch(static_cast<size_t>(W));
    std::vector<uint8_t> scored(static_cast<size_t>(W));
    for (int cy = 0; cy < CH; ++cy) {
      for (size_t ti = 0; ti < test.size(); ++ti)
        eval.Evaluate(int(ti), int64_t(cy) * CW, CW, C, pred.data() + ti * C * CW);
      const int y_end = cy == CH - 1 ? fine.height() : std::min(fine.height(), (cy + 1) << k);
      for (int y = cy << k; y < y_end; ++y) {
        for (int x = 0; x < W; ++x) {
          const int64_t p = int64_t(y) * W + x;
          scored[size_t(x)] = 0;
          if (fine.has_mask() && !fine.mask[p]) continue;
          const int64_t q = int64_t(cy) * CW + std::min(CW - 1, x >> k);
          if (fit->status[q] == kTexelMasked) continue;  // the coarser mask leaves it out
          ++h.scored;
          if (fit->status[q] != kTexelOk) {
            ++h.flagged;
            continue;
          }
          scored[size_t(x)] = 1;
        }
        if (near) nr.Set(fine, y, k, CW, cy);
        for (size_t ti = 0; ti < test.size(); ++ti) {
          const int i = test[ti];
          const double w = std::max(0.0f, test_dirs[ti].z);
          if (near)
            near_eval.Evaluate(fine.lights()[size_t(i)], nr.texels.data(), nr.points.data(), W,
                               nr.pred.data());
          for (int c = 0; c < C; ++c) {
            const float* row = fine.Row(i, c, y, 0, W, scratch.data());
            const float* pr = pred.data() + (ti * C + size_t(c)) * CW;
            const float* npr = near ? nr.pred.data() + size_t(c) * W : nullptr;
            const float s = inv[size_t(i) * C + c];
            for (int x = 0; x < W; ++x) {
              const float raw = row[x];
              if (!scored[size_t(x)] || !std::isfinite(raw) || (clip && raw >= kClipLevel))
                continue;
              const float predicted = near ? npr[x] : pr[std::min(CW - 1, x >> k)];
              // sRGB: the codes of the sample and of the prediction times the light's intensity
              // (as fit/metrics.h scores held-out lights), in units of full scale.
              const double d =
                  srgb8 && !environment
                      ? (int(LinearToSrgb8Fast(predicted / s)) - int(LinearToSrgb8Fast(raw))) /
                            255.0
                      : predicted - raw * s;
              h.sse[size_t(i)] += d * d, ++h.count[size_t(i)];
              if (environment) {
                const size_t e = size_t(int64_t(y) * W + x) * C + c;
                h.env_err[e] += w * d, h.env_w[e] += w;
                if (srgb8) h.env_pred[e] += w * predicted, h.env_meas[e] += w * raw * s;
              }
            }
          }
        }
      }
    }
    h.last_maps = std::move(fit->maps);
  }
  // A band of a distributed stack: every band's sums (per image; texels scored and flagged).
  SumOverBands(fine, h.sse.data(), n);
  SumOverBands(fine, h.count.data(), n);
  int64_t texels[2] = {h.scored, h.flagged};
  SumOverBands(fine, texels, 2);
  h.scored = texels[0], h.flagged = texels[1];
  return h;
}

double AngleDeg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(Dot(Normalize(a), Normalize(b)), -1.0, 1.0)) * 180 / M_PI;
}

// Per-image weights of the scene's light: 1 (dynamic), or a 15° Gaussian around a static sun;
// all 1 with a warning when no light lies within 30° of the sun.
std::vector<double> LightWeights(const LightStack& s, const SceneSpec& scene,
                                 std::vector<std::string>* warnings) {
  std::vector<double> w(size_t(s.num_images()), 1.0);
  if (!scene.static_light || scene.environment) return w;
  const Vec3 sun = DirectionFromAnglesDeg(scene.sun_theta_deg, scene.sun_phi_deg);
  double best = 180;
  for (size_t i = 0; i < w.size(); ++i) {
    const double a = AngleDeg(s.lights()[i].direction, sun);
    best = std::min(best, a);
    w[i] = std::exp(-std::pow(a / 15.0, 2));
  }
  if (best > 30) {
    if (warnings)
      warnings->push_back("no measured light lies within 30° of the scene's sun (nearest " +
                          std::to_string(int(best)) +
                          "°): the error there is extrapolated; all lights are weighted alike");
    std::fill(w.begin(), w.end(), 1.0);
  }
  return w;
}

double SceneError(const LightStack& fine, const HeldOutSums& h, const std::vector<double>& w,
                  const SceneSpec& scene) {
  if (scene.environment) {
    double e2 = 0, k = 0;
    for (size_t j = 0; j < h.env_err.size(); ++j) {
      if (!(h.env_w[j] > 0)) continue;
      const double d = scene.srgb8 ? (int(LinearToSrgb8Fast(float(h.env_pred[j] / h.env_w[j]))) -
                                      int(LinearToSrgb8Fast(float(h.env_meas[j] / h.env_w[j])))) /
                                         255.0
                                   : h.env_err[j] / h.env_w[j];
      e2 += d * d, ++k;
    }
    double sums[2] = {e2, k};  // over every band of a distributed stack
    SumOverBands(fine, sums, 2);
    return sums[1] > 0 ? std::sqrt(sums[0] / sums[1]) : NAN;
  }
  double num = 0, den = 0;
  for (size_t i = 0; i < w.size(); ++i) num += w[i] * h.sse[i], den += w[i] * double(h.count[i]);
  return den > 0 ? std::sqrt(num / den) : NAN;
}

}  // namespace

bool SceneSpec::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    *why = (source.empty() ? "" : source + ": ") + m;
    return false;
  };
  if (!(texel_footprint_px > 0) || !std::isfinite(texel_footprint_px))
    return fail("texel_footprint_px must be > 0 (screen pixels per texel), got " +
                std::to_string(texel_footprint_px));
  if (!(error_budget > 0) || !std::isfinite(error_budget))
    return fail("error_budget must be > 0 (held-out RMSE in the error_metric's unit), got " +
                std::to_string(error_budget));
  if (memory_budget_bytes < 0 || !std::isfinite(memory_budget_bytes))
    return fail("memory_budget_bytes must be ≥ 0 (0 = unlimited)");
  if (!(view_theta_max_deg >= 0 && view_theta_max_deg <= 90))
    return fail("view_theta_max_deg must be in [0, 90] (the most oblique camera), got " +
                std::to_string(view_theta_max_deg));
  if (static_light && !environment && !(sun_theta_deg >= 0 && sun_theta_deg < 90))
    return fail("sun_theta_deg must be in [0, 90), got " + std::to_string(sun_theta_deg));
  return true;
}

StatusOr<SceneSpec> ParseScene(const std::string& text, const std::string& source) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, or out_of_range (a number like 1e999)
    return InvalidArgument(source + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object()) return InvalidArgument(source + ": the scene must be a JSON object");
  SceneSpec s;
  s.source = source;
  auto number = [&](const char* key, double* out) -> Status {
    if (!j.contains(key)) return Status::Ok();
    if (!j[key].is_number())
      return InvalidArgument(source + ": field '" + key + "' must be a number");
    *out = j[key].get<double>();
    return Status::Ok();
  };
  static const char* kKeys[] = {
      "schema",      "texel_footprint_px",  "lighting",           "light",        "sun_theta_deg",
      "sun_phi_deg", "memory_budget_bytes", "view_theta_max_deg", "error_budget", "error_metric",
      "description"};
  for (const auto& item : j.items()) {
    const std::string& k = item.key();  // lambdas cannot capture structured bindings (clang)
    if (std::none_of(std::begin(kKeys), std::end(kKeys), [&](const char* x) { return k == x; }))
      return InvalidArgument(source + ": unknown field '" + k +
                             "' (known: texel_footprint_px, lighting, light, sun_theta_deg, "
                             "sun_phi_deg, memory_budget_bytes, view_theta_max_deg, error_budget, "
                             "error_metric)");
  }
  if (j.contains("schema") && j["schema"] != "matfit.scene/1")
    return InvalidArgument(source + ": field 'schema' must be \"matfit.scene/1\"");
  MATFIT_RETURN_IF_ERROR(number("texel_footprint_px", &s.texel_footprint_px));
  MATFIT_RETURN_IF_ERROR(number("sun_theta_deg", &s.sun_theta_deg));
  MATFIT_RETURN_IF_ERROR(number("sun_phi_deg", &s.sun_phi_deg));
  MATFIT_RETURN_IF_ERROR(number("memory_budget_bytes", &s.memory_budget_bytes));
  MATFIT_RETURN_IF_ERROR(number("error_budget", &s.error_budget));
  MATFIT_RETURN_IF_ERROR(number("view_theta_max_deg", &s.view_theta_max_deg));
  if (j.contains("lighting")) {
    const auto& v = j["lighting"];
    if (v != "dynamic" && v != "static")
      return InvalidArgument(source + ": field 'lighting' must be \"dynamic\" or \"static\"");
    s.static_light = v == "static";
  }
  if (j.contains("error_metric")) {
    const auto& v = j["error_metric"];
    if (v != "linear" && v != "srgb8")
      return InvalidArgument(source + ": field 'error_metric' must be \"linear\" or \"srgb8\"");
    s.srgb8 = v == "srgb8";
  }
  if (j.contains("light")) {
    const auto& v = j["light"];
    if (v != "directional" && v != "environment")
      return InvalidArgument(source + ": field 'light' must be \"directional\" or \"environment\"");
    s.environment = v == "environment";
  }
  std::string why;
  if (!s.Check(&why)) return InvalidArgument(why);
  return s;
}

int SceneLevel(const SceneSpec& scene, int width, int height) {
  // From the footprint (linear: texel width on screen in pixels), clamped so the shown stack
  // keeps ≥ 4 texels per side.
  const double want = std::floor(std::log2(1.0 / scene.texel_footprint_px) + 1e-9);
  int level = int(std::clamp(want, 0.0, 30.0));
  while (level > 0 && (std::min(width, height) >> level) < 4) --level;
  return level;
}

int SelectionRowMultiple(const SceneSpec& scene, int width, int height, const SelectOptions& o) {
  const int level = SceneLevel(scene, width, height);
  const int fw = width >> level, fh = height >> level;  // DownsampleStack's floor
  int k = 0;  // the coarsest candidate level, as SelectModel's table stops
  while (k < o.max_coarser_levels && (fw >> (k + 1)) >= 4 && (fh >> (k + 1)) >= 4) ++k;
  return 1 << (level + k);
}

StatusOr<Selection> SelectModel(const LightStack& stack, const SceneSpec& scene,
                                const SelectOptions& o) {
  std::string why;
  if (!scene.Check(&why)) return InvalidArgument(why);
  if (o.folds < 2) return InvalidArgument("selection needs ≥ 2 held-out folds");
  if (stack.num_images() < 3)
    return InvalidArgument(
        "--model auto scores candidates on held-out lights and needs ≥ 3 "
        "images; the dataset has " +
        std::to_string(stack.num_images()) + ": name a model instead");
  const int folds = std::min(o.folds, stack.num_images());
  Selection sel;
  // A band of a distributed stack selects for the whole stack (its sizes are the whole one's).
  const int level = SceneLevel(scene, stack.width(), stack.full_height());
  const double want = std::floor(std::log2(1.0 / scene.texel_footprint_px) + 1e-9);
  if (level < want)
    sel.warnings.push_back(
        Warning(WarningCode::kMipFootprint,
                "the scene's footprint asks for mip " + std::to_string(int(want)) + "; the " +
                    std::to_string(stack.width()) + "x" + std::to_string(stack.full_height()) +
                    " dataset stops at mip " + std::to_string(level)));
  sel.scene_level = level;
  auto fine = DownsampleStack(stack, 1 << level);
  if (!fine.ok()) return fine.status();
  if (const StackDiagnostics d = DiagnoseStack(*fine); d.looks_gamma_encoded)
    return InvalidArgument("model selection: " + d.warnings.front());
  // A multi-view stack (every view of a BTF) is fitted by the methods over views only.
  std::vector<std::string> methods = !o.methods.empty()      ? o.methods
                                     : stack.is_multi_view() ? MultiViewMethodNames()
                                                             : MethodNames();
  std::vector<std::pair<std::unique_ptr<FitMethod>, int>> cands;  // method, k
  std::vector<Candidate> table;
  for (const auto& name : methods) {
    auto m = MakeMethod(name);
    if (!m) return InvalidArgument("selection: '" + name + "' is not a method");
    for (int k = 0; k <= o.max_coarser_levels; ++k) {
      const int w = fine->width() >> k, h = fine->full_height() >> k;
      if (k > 0 && (w < 4 || h < 4)) break;
      Candidate c;
      c.method = name;
      c.level = level + k, c.width = w, c.height = h;
      c.bytes = int64_t(m->bytes_per_texel()) * w * h;
      table.push_back(c);
      cands.emplace_back(MakeMethod(name), k);
    }
  }
  // Fewest bytes first; ties: fewer parameters, then finer maps.
  std::vector<size_t> order(table.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (table[a].bytes != table[b].bytes) return table[a].bytes < table[b].bytes;
    const int pa = cands[a].first->parameters_per_texel(),
              pb = cands[b].first->parameters_per_texel();
    if (pa != pb) return pa < pb;
    return table[a].level < table[b].level;
  });
  std::vector<StatusOr<LightStack>> coarse;
  // The levels the table holds (as SelectionRowMultiple counts them): a distributed stack's
  // bands are whole blocks of these, not of coarser ones.
  for (int k = 0; k <= o.max_coarser_levels; ++k) {
    if (k > 0 && ((fine->width() >> k) < 4 || (fine->full_height() >> k) < 4)) break;
    coarse.push_back(DownsampleStack(*fine, 1 << k));
  }
  const size_t warnings_before = sel.warnings.size();
  const std::vector<double> weights = LightWeights(*fine, scene, &sel.warnings);
  const bool sun_fallback = sel.warnings.size() > warnings_before;
  // The user's fit options, with cancellation forwarded (progress counts candidates).
  FitOptions fit_options = o.fit;
  int64_t done = 0;
  if (o.fit.progress)
    fit_options.progress = [&](int64_t, int64_t) {
      return o.fit.progress(done, int64_t(table.size()));
    };
  int chosen = -1, best = -1;
  for (size_t idx : order) {
    Candidate& c = table[idx];
    if (chosen >= 0) {
      c.note = "not evaluated: a smaller candidate met the budget";
      sel.candidates.push_back(c);
      continue;
    }
    // A model the lights cannot support (fit/light_cover.h) is never chosen.
    if (std::string cover = LightCoverShortfall(fine->lights(), *cands[idx].first);
        !cover.empty()) {
      c.note = "overfit risk: " + cover;
      sel.candidates.push_back(c);
      continue;
    }
    if (scene.memory_budget_bytes > 0 && double(c.bytes) > scene.memory_budget_bytes) {
      c.note = "over the memory budget";
      sel.candidates.push_back(c);
      continue;
    }
    const int k = cands[idx].second;
    if (!coarse[k].ok()) {
      c.note = coarse[k].status().message();
      sel.candidates.push_back(c);
      continue;
    }
    auto h = Score(*cands[idx].first, *fine, *coarse[k], k, folds, fit_options, scene.environment,
                   scene.srgb8);
    if (!h.ok()) return h.status();
    c.evaluated = true;
    c.fit_seconds = h->fit_seconds;
    c.flagged_fraction = h->scored ? double(h->flagged) / h->scored : 1;
    c.error = h->any ? SceneError(*fine, *h, weights, scene) : NAN;
    c.render_ns_per_pixel = h->any ? ShadingCostNs(h->last_maps) : 0;
    if (h->failed_folds > 0)
      c.note = std::to_string(h->failed_folds) + " of " + std::to_string(folds) +
               " held-out folds could not be fitted: " + h->fold_error;
    else if (c.flagged_fraction > 0.01)
      c.note = "flags " + std::to_string(int(100 * c.flagged_fraction)) + " % of its texels";
    else if (!(c.error <= scene.error_budget))
      c.note = "error above the budget";
    else
      c.meets = true;
    if (c.meets) chosen = int(sel.candidates.size());
    if (std::isfinite(c.error) && c.flagged_fraction <= 0.01 && h->failed_folds == 0 &&
        (best < 0 || c.error < sel.candidates[best].error))
      best = int(sel.candidates.size());
    sel.candidates.push_back(c);
    ++done;
    if (o.fit.progress && !o.fit.progress(done, int64_t(table.size())))
      return Status(StatusCode::kCancelled, "cancelled");
  }
  int pick = chosen;
  if (pick < 0) {
    sel.budget_met = false;
    pick = best;
    if (pick < 0)
      return InvalidArgument(
          std::string("model selection: no candidate could be scored (") +
          (sel.candidates.empty() ? "the dataset is too small"
           : done == 0            ? "every candidate is over the memory budget"
                                  : "every candidate flags > 1 % of its texels or fails a fold") +
          "); see the candidates in a fit with a named model, or relax the scene");
    sel.warnings.push_back(
        Warning(WarningCode::kBudgetNotMet,
                "no candidate met the error budget " + std::to_string(scene.error_budget) +
                    "; using the most accurate one, " + sel.candidates[pick].method));
  }
  const Candidate& c = sel.candidates[pick];
  sel.method = c.method;
  sel.level = c.level, sel.width = c.width, sel.height = c.height;
  sel.error = c.error;
  const std::string weighting = std::string(scene.environment ? "environment-light"
                                            : (scene.static_light && !sun_fallback) ? "sun-weighted"
                                                                                    : "all-light") +
                                (scene.srgb8 ? " 8-bit sRGB" : "");
  char buf[480];
  if (sel.budget_met)
    std::snprintf(buf, sizeof buf,
                  "%s at %dx%d (mip %d; the scene shows mip %d): held-out %s error %.4g meets the "
                  "budget %.4g with %lld bytes of maps; candidates are tried from the fewest bytes "
                  "up and this was the first to meet it (%d evaluated)",
                  c.method.c_str(), c.width, c.height, c.level, level, weighting.c_str(), c.error,
                  scene.error_budget, (long long)c.bytes, int(done));
  else
    std::snprintf(buf, sizeof buf,
                  "%s at %dx%d (mip %d; the scene shows mip %d): no candidate meets the budget "
                  "%.4g; this is the most accurate of the %d evaluated, held-out %s error %.4g, "
                  "%lld bytes of maps",
                  c.method.c_str(), c.width, c.height, c.level, level, scene.error_budget,
                  int(done), weighting.c_str(), c.error, (long long)c.bytes);
  sel.reason = buf;
  return sel;
}

LightStack ScenesViews(const LightStack& s, const SceneSpec& scene) {
  if (!s.is_multi_view()) return s;
  const auto groups = ViewGroups(s);
  const int frontal = MostFrontalView(s, groups);
  std::vector<int> kept_groups;
  for (int g = 0; g < int(groups.size()); ++g) {
    double theta = 0, phi = 0;
    AnglesDegFromDirection(s.ViewOf(groups[size_t(g)][0]), &theta, &phi);
    if (g == frontal || theta <= scene.view_theta_max_deg + 0.5) kept_groups.push_back(g);
  }
  if (kept_groups.size() == 1) return SelectView(s, groups[size_t(frontal)]);
  std::vector<int> images;
  for (int g : kept_groups)
    images.insert(images.end(), groups[size_t(g)].begin(), groups[size_t(g)].end());
  std::sort(images.begin(), images.end());
  LightStack out = SelectImages(s, images);
  return out;
}

std::string SelectionJson(const Selection& s, const SceneSpec& scene) {
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(); };
  json cands = json::array();
  for (const auto& c : s.candidates)
    cands.push_back({{"method", c.method},
                     {"level", c.level},
                     {"width", c.width},
                     {"height", c.height},
                     {"bytes", c.bytes},
                     {"evaluated", c.evaluated},
                     {"error", num(c.error)},
                     {"flagged_fraction", c.flagged_fraction},
                     {"fit_seconds", num(c.fit_seconds)},
                     {"render_ns_per_pixel", num(c.render_ns_per_pixel)},
                     {"meets_budget", c.meets},
                     {"note", c.note}});
  json j = {{"chosen", s.method},
            {"level", s.level},
            {"scene_level", s.scene_level},
            {"width", s.width},
            {"height", s.height},
            {"error", num(s.error)},
            {"budget_met", s.budget_met},
            {"reason", s.reason},
            {"warnings", s.warnings},
            {"views", {{"fitted", s.views}, {"in_data", s.views_in_data}}},
            {"scene",
             {{"texel_footprint_px", scene.texel_footprint_px},
              {"lighting", scene.static_light ? "static" : "dynamic"},
              {"light", scene.environment ? "environment" : "directional"},
              {"sun_theta_deg", scene.sun_theta_deg},
              {"sun_phi_deg", scene.sun_phi_deg},
              {"memory_budget_bytes", scene.memory_budget_bytes},
              {"view_theta_max_deg", scene.view_theta_max_deg},
              {"error_budget", scene.error_budget},
              {"error_metric", scene.srgb8 ? "srgb8" : "linear"},
              {"source", scene.source}}},
            {"candidates", cands}};
  return j.dump();
}

}  // namespace matfit::fit
