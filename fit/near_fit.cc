#include "fit/near_fit.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <vector>

#include "core/near_lights.h"
#include "core/parallel.h"
#include "core/warnings.h"
#include "fit/methods.h"

namespace matfit::fit {

namespace {

// One pass over the plan's tiles (pass `pass` of `passes` for progress), merged into one result.
// With step > 1 only the tiles (tx, ty) with tx ≡ ty ≡ step/2 (mod step) are fitted; the others'
// texels stay masked.
StatusOr<FitResult> FitTiles(const std::string& method, const FitFn& fit, const LightStack& s,
                             const NearTilePlan& plan, const FitOptions& o, int pass, int passes,
                             int step = 1) {
  const int64_t count = plan.count();
  std::vector<StatusOr<FitResult>> tiles(static_cast<size_t>(count),
                                         Status(StatusCode::kInternal, "not run"));
  std::vector<int> x0(static_cast<size_t>(count)), y0(static_cast<size_t>(count));
  std::vector<char> masked(static_cast<size_t>(count), 0);  // tiles with nothing to fit
  FitOptions inner = o;
  // One tile (far lamps): the fit's own progress and cancellation; several: tiles done.
  if (count == 1 && o.progress)
    inner.progress = [&o, pass, passes](int64_t d, int64_t t) {
      return o.progress(pass * t + d, passes * t);
    };
  else
    inner.progress = {};
  std::atomic<int64_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;
  ParallelFor(0, count, [&](int64_t b, int64_t e) {
    for (int64_t t = b; t < e && !cancelled; ++t) {
      const int tx = int(t % plan.tiles_x), ty = int(t / plan.tiles_x);
      if (tx % step != step / 2 || ty % step != step / 2) {
        masked[size_t(t)] = 1;
      } else {
        auto tile = NearTileStack(s, plan, tx, ty, &x0[size_t(t)], &y0[size_t(t)]);
        if (!tile.ok()) {
          tiles[size_t(t)] = tile.status();
          continue;
        }
        if (tile->has_mask() && tile->MaskedTexels() == 0)
          masked[size_t(t)] = 1;
        else
          tiles[size_t(t)] = fit(*tile, inner);
      }
      const int64_t d = ++done;
      if (o.progress && count > 1) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (!o.progress(pass * count + d, passes * count)) cancelled = true;
      }
    }
  });
  if (cancelled) return Status(StatusCode::kCancelled, "cancelled");
  FitResult out;
  out.maps.width = s.width(), out.maps.height = s.height();
  out.status.assign(size_t(s.plane_size()), uint8_t(kTexelMasked));
  bool first = true;
  std::map<std::string, std::pair<double, double>> shared;  // Σ value · texels, Σ texels
  std::map<std::string, double> worst;                      // condition numbers: the largest
  for (int64_t t = 0; t < count; ++t) {
    if (masked[size_t(t)]) continue;  // its texels stay masked
    const auto& r = tiles[size_t(t)];
    if (!r.ok())
      return Status(r.status().code(), r.status().message() + " (near lights: tile at texel " +
                                           std::to_string(x0[size_t(t)]) + "," +
                                           std::to_string(y0[size_t(t)]) + ")");
    const FitResult& f = *r;
    if (first) {  // the model's scalar fields (kind, basis terms, flags) from the first tile
      const MaterialMaps meta = CropMaps(f.maps, 0, 0, 1, 1);
      out.maps = meta;
      out.maps.width = s.width(), out.maps.height = s.height();
      out.method = f.method;
      first = false;
    }
    PasteMaps(f.maps, x0[size_t(t)], y0[size_t(t)], &out.maps);
    const int w = f.maps.width, h = f.maps.height;
    for (int r2 = 0; r2 < h; ++r2) {
      std::copy_n(f.status.data() + size_t(r2) * w, w,
                  out.status.data() + size_t(y0[size_t(t)] + r2) * s.width() + x0[size_t(t)]);
      if (!f.dropped_lights.empty()) {
        if (out.dropped_lights.empty()) out.dropped_lights.assign(size_t(s.plane_size()), 0);
        std::copy_n(
            f.dropped_lights.data() + size_t(r2) * w, w,
            out.dropped_lights.data() + size_t(y0[size_t(t)] + r2) * s.width() + x0[size_t(t)]);
      }
    }
    out.flagged_texels += f.flagged_texels, out.refit_texels += f.refit_texels;
    out.dropped_samples += f.dropped_samples;
    for (const auto& [k, v] : f.parameters) {
      if (k.find("condition") != std::string::npos) {  // a worst case: the largest tile's
        worst[k] = std::max(worst.count(k) ? worst[k] : v, v);
        continue;
      }
      shared[k].first += v * double(w) * h, shared[k].second += double(w) * h;
    }
    for (const std::string& wmsg : f.warnings)
      if (std::find(out.warnings.begin(), out.warnings.end(), wmsg) == out.warnings.end())
        out.warnings.push_back(wmsg);
  }
  if (first && step > 1)  // the sampled tiles hold no texel to fit (the caller fits every tile)
    return Status(StatusCode::kNotFound, method + ": no texel to fit in the sampled tiles");
  if (first) return InvalidArgument(method + ": every texel is masked; nothing to fit");
  for (const auto& [k, v] : shared) out.parameters[k] = v.first / v.second;
  for (const auto& [k, v] : worst) out.parameters[k] = v;
  return out;
}

}  // namespace

StatusOr<FitResult> FitNearLights(const std::string& method, const FitFn& fit, const LightStack& s,
                                  const FitOptions& o) {
  if (method == "heinrich")
    return InvalidArgument(
        "heinrich: near lights (light_positions.txt) are not supported by the seed method, whose "
        "specular reference is the image lit along the view (θl = θv = 0) — a near lamp is that "
        "only at the image centre; use blinn-phong or cook-torrance, or --distant-lights");
  if (method.starts_with("rbf"))
    return InvalidArgument(method +
                           ": near lights (light_positions.txt) are not supported by the "
                           "radial-basis model, whose light basis is one table per fit; use "
                           "another model, or --distant-lights to treat the lights as distant");
  if (s.is_band())
    return InvalidArgument(
        "near lights (light_positions.txt) are not supported in a distributed fit yet; run "
        "one process, or pass --distant-lights");
  if (Status st = CheckLightPositions(s); !st.ok()) return st;
  const auto t0 = std::chrono::steady_clock::now();
  NearLightOptions no;
  no.max_direction_error_deg = o.near_tolerance_deg;
  const NearTilePlan plan = PlanNearTiles(s, no);
  // Lobe models share one lobe shape over the material: a first pass fits tiles with a
  // per-texel shape, the shape is the median over their texels (the whole-stack fit's
  // estimator), and the second pass fits every tile with it fixed. (Per tile, a few texels would
  // overfit it.) The first pass fits every step-th tile in x and y, step = ⌊√(F / N)⌋ for the F
  // texels in the mask and N = lobe_shape_texels (at most the tiles across or down; 0: every
  // tile), so about N texels in tiles spread over the image (the distant-light fit's grid,
  // in tiles); without a shape there, every tile.
  const bool two_pass = HasSharedLobeShape(method) && !o.per_texel_lobe && o.lobe_shape.empty();
  const int passes = two_pass ? 2 : 1;
  int64_t shape_texels = 0;  // the texels the shape is the median of
  auto result = [&]() -> StatusOr<FitResult> {
    if (!two_pass) return FitTiles(method, fit, s, plan, o, 0, passes);
    FitOptions first = o;
    first.per_texel_lobe = true;
    const int step =
        o.lobe_shape_texels == 0
            ? 1
            : std::clamp(int(std::sqrt(double(s.MaskedTexels()) / double(o.lobe_shape_texels))), 1,
                         std::max(1, std::min(plan.tiles_x, plan.tiles_y)));
    auto pass1 = FitTiles(method, fit, s, plan, first, 0, passes, step);
    auto shape = pass1.ok() ? SharedLobeShape(method, s, pass1->maps, pass1->status)
                            : StatusOr<std::vector<double>>(pass1.status());
    auto fitted = [&] {
      int64_t k = 0;
      for (uint8_t st : pass1->status) k += st == kTexelOk;
      return k;
    };
    // Nothing to take the median of in the sampled tiles (no texel, no lobe), or fewer than a
    // quarter of the texels asked for (a small or uneven mask): every tile. A cancel or a
    // tile's error is returned as it is.
    if (step > 1 &&
        ((!shape.ok() && shape.status().code() == StatusCode::kNotFound) ||
         (shape.ok() && fitted() < std::min(int64_t(o.lobe_shape_texels), s.MaskedTexels()) / 4))) {
      pass1 = FitTiles(method, fit, s, plan, first, 0, passes);
      if (pass1.ok()) shape = SharedLobeShape(method, s, pass1->maps, pass1->status);
    }
    if (!pass1.ok()) return pass1;
    shape_texels = fitted();
    if (!shape.ok() && shape.status().code() == StatusCode::kNotFound) {
      pass1->warnings.push_back(Warning(WarningCode::kNoSpecularLobe,
                                        "no texel shows a specular lobe; kept the per-texel fit"));
      return pass1;
    }
    if (!shape.ok()) return shape.status();
    FitOptions second = o;
    second.lobe_shape = *shape;
    return FitTiles(method, fit, s, plan, second, 1, passes);
  }();
  if (!result.ok()) return result;
  FitResult& out = *result;
  out.parameters["near_tile_texels"] = plan.tile;
  out.parameters["near_tiles"] = double(plan.count());
  out.parameters["near_max_direction_error_deg"] = plan.max_direction_error_deg;
  out.parameters["near_max_falloff_error"] = plan.max_falloff_error;
  out.parameters["near_nearest_light_px"] = plan.nearest_light_px;
  if (shape_texels > 0) out.parameters["lobe_shape_texels"] = double(shape_texels);
  out.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace matfit::fit
