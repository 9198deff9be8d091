#include "core/near_lights.h"

#include <algorithm>
#include <cmath>

#include "core/model/model.h"
#include "core/stack_ops.h"

namespace matfit {

Vec3 NearTexelPosition(const LightStack& s, double x, double y) {
  const NearFrame& f = s.near_frame;
  return {f.x0 + x * f.step, f.y0 - y * f.step, 0.0};
}

double NearFalloff(const LightSample& l, const Vec3& x) {
  if (!l.has_position) return 1.0;
  const Vec3 d = l.position - x;
  return Dot(l.position, l.position) / Dot(d, d);
}

LightSample LightSeenFrom(const LightSample& l, const Vec3& x) {
  if (!l.has_position) return l;
  LightSample out = l;
  out.direction = Normalize(l.position - x);
  const double f = NearFalloff(l, x);
  out.intensity = Vec3(l.intensity.x * f, l.intensity.y * f, l.intensity.z * f);
  out.has_position = false;
  return out;
}

void NearLightEvaluator::Evaluate(const LightSample& light, const int64_t* map_texels,
                                  const Vec3* points, int n, float* out) {
  l_.resize(size_t(n)), falloff_.resize(size_t(n));
  v_.assign(size_t(n), view_);
  for (int t = 0; t < n; ++t) {
    l_[size_t(t)] = Vec3f(Normalize(light.position - points[t]));
    falloff_[size_t(t)] = float(NearFalloff(light, points[t]));
  }
  Model(maps_.model).EvaluateSamples(maps_, map_texels, l_.data(), v_.data(), n, out);
  for (int c = 0; c < 3; ++c)
    for (int t = 0; t < n; ++t) out[size_t(c) * n + t] *= falloff_[size_t(t)];
}

namespace {

// Worst direction (degrees) and relative fall-off error over the tile [x0, x1) × [y0, y1).
void TileErrors(const LightStack& s, int x0, int y0, int x1, int y1, double* dir_deg,
                double* falloff) {
  const double cx = 0.5 * (x0 + x1 - 1), cy = 0.5 * (y0 + y1 - 1);
  const Vec3 c = NearTexelPosition(s, cx, cy);
  const double xs[3] = {double(x0), cx, double(x1 - 1)}, ys[3] = {double(y0), cy, double(y1 - 1)};
  for (const LightSample& l : s.lights()) {
    const Vec3 lc = Normalize(l.position - c);
    const double fc = NearFalloff(l, c);
    auto probe = [&](double x, double y) {
      const Vec3 p = NearTexelPosition(s, x, y);
      const double cosang = std::clamp(Dot(Normalize(l.position - p), lc), -1.0, 1.0);
      *dir_deg = std::max(*dir_deg, std::acos(cosang) * 180 / M_PI);
      *falloff = std::max(*falloff, std::abs(fc / NearFalloff(l, p) - 1));
    };
    for (double x : xs)
      for (double y : ys) probe(x, y);
    // The texel nearest below the light: where the fall-off peaks.
    const double fx = (l.position.x - s.near_frame.x0) / s.near_frame.step;
    const double fy = (s.near_frame.y0 - l.position.y) / s.near_frame.step;
    probe(std::clamp(fx, double(x0), double(x1 - 1)), std::clamp(fy, double(y0), double(y1 - 1)));
  }
}

}  // namespace

NearTilePlan PlanNearTiles(const LightStack& s, const NearLightOptions& o) {
  NearTilePlan best;
  const int W = s.width(), H = s.height();
  for (int tile = 512;; tile /= 2) {
    NearTilePlan p;
    p.tile = tile, p.tiles_x = (W + tile - 1) / tile, p.tiles_y = (H + tile - 1) / tile;
    for (int ty = 0; ty < p.tiles_y; ++ty)
      for (int tx = 0; tx < p.tiles_x; ++tx)
        TileErrors(s, tx * tile, ty * tile, std::min(W, (tx + 1) * tile),
                   std::min(H, (ty + 1) * tile), &p.max_direction_error_deg, &p.max_falloff_error);
    best = p;
    if (tile == 1 || (p.max_direction_error_deg <= o.max_direction_error_deg &&
                      p.max_falloff_error <= o.max_falloff_error))
      break;
  }
  // The closest any light comes to a texel: to the texel nearest below it.
  double nearest = INFINITY;
  for (const LightSample& l : s.lights()) {
    const double fx = (l.position.x - s.near_frame.x0) / s.near_frame.step;
    const double fy = (s.near_frame.y0 - l.position.y) / s.near_frame.step;
    const Vec3 d = l.position - NearTexelPosition(s, std::clamp(fx, 0.0, double(W - 1)),
                                                  std::clamp(fy, 0.0, double(H - 1)));
    nearest = std::min(nearest, std::sqrt(Dot(d, d)));
  }
  best.nearest_light_px = nearest;
  return best;
}

StatusOr<LightStack> NearTileStack(const LightStack& s, const NearTilePlan& plan, int tx, int ty,
                                   int* x0, int* y0) {
  const int x = tx * plan.tile, y = ty * plan.tile;
  const int w = std::min(s.width() - x, plan.tile), h = std::min(s.height() - y, plan.tile);
  auto tile = CropStack(s, x, y, w, h);
  if (!tile.ok()) return tile.status();
  const Vec3 c = NearTexelPosition(s, x + 0.5 * (w - 1), y + 0.5 * (h - 1));
  for (LightSample& l : tile->lights()) l = LightSeenFrom(l, c);
  if (x0) *x0 = x;
  if (y0) *y0 = y;
  return tile;
}

Status CheckLightPositions(const LightStack& s) {
  const auto& ls = s.lights();
  for (size_t i = 0; i < ls.size(); ++i) {
    if (ls[i].has_position != ls[0].has_position)
      return DataError("light " + std::to_string(i) +
                       (ls[i].has_position ? " has a position but light 0 has none"
                                           : " has no position but light 0 has one") +
                       ": give every light a position or none");
    if (!ls[i].has_position) continue;
    const Vec3& p = ls[i].position;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || p.z <= 0)
      return DataError("light " + std::to_string(i) + " is at (" + std::to_string(p.x) + ", " +
                       std::to_string(p.y) + ", " + std::to_string(p.z) +
                       "): a light's position must be finite and above the sample (z > 0, "
                       "source pixels)");
  }
  return Status::Ok();
}

}  // namespace matfit
