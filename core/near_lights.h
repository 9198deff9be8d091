// Near (point) lights: lights at positions (LightSample::has_position) seen from each texel —
// the direction toward the light and the inverse-square fall-off. Pure computation.
//
// A light at P with intensity I at the frame origin O lights the texel at X with
//   l(X) = (P − X) / |P − X|,   I(X) = I · |P − O|² / |P − X|²   (isotropic point source).
// Fits run on tiles small enough that one distant light per tile (the light seen from the
// tile's centre) is within a tolerance of every texel's (PlanNearTiles).
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

// Position of texel (x, y) (column, row; fractional allowed) in the stack's NearFrame.
Vec3 NearTexelPosition(const LightStack& stack, double x, double y);

// Light `l` (with a position) as seen from the point X: direction toward it and the intensity
// there; the angles theta/phi stay the light's nominal ones (as seen from the origin), so
// figures grouped by elevation group the same lights everywhere. Without a position: `l`.
LightSample LightSeenFrom(const LightSample& l, const Vec3& x);

// Texel (x, y)'s fall-off factor |P − O|² / |P − X|² for a light with a position (1 without).
double NearFalloff(const LightSample& l, const Vec3& x);

// One light's prediction at scattered texels, each lit along its own direction and scaled by its
// own fall-off (the residual raw / I − prediction is then in units of the light's nominal
// intensity): out[c · n + t] = NearFalloff · R(maps texel map_texels[t], light seen from
// points[t], view), c < 3 — channel 0 first, so a grey stack reads the first n. Not
// thread-safe (scratch): one per thread. The scorer, the selection's held-out ranking and the
// synthetic renderer evaluate near lights through it.
class NearLightEvaluator {
 public:
  NearLightEvaluator(const MaterialMaps& maps, const Vec3f& view) : maps_(maps), view_(view) {}
  void Evaluate(const LightSample& light, const int64_t* map_texels, const Vec3* points, int n,
                float* out);

 private:
  const MaterialMaps& maps_;
  Vec3f view_;
  std::vector<Vec3f> l_, v_;
  std::vector<float> falloff_;
};

struct NearLightOptions {
  // The largest angle between a texel's own light direction and its tile's (degrees), and the
  // largest relative difference of their fall-off factors.
  double max_direction_error_deg = 0.25;
  double max_falloff_error = 0.005;
};

struct NearTilePlan {
  int tile = 0;  // side in texels (tiles at multiples of it; the last ones cut)
  int tiles_x = 0, tiles_y = 0;
  // Measured over every tile and light (at the tile's corners, edge midpoints and the point
  // nearest below each light): the worst direction and fall-off error of the plan.
  double max_direction_error_deg = 0, max_falloff_error = 0;
  // How close any light comes to a texel, in source pixels (the rig's scale).
  double nearest_light_px = 0;
  int64_t count() const { return int64_t(tiles_x) * tiles_y; }
};

// The largest tile side (from 512 down to 1 texel) whose errors are within the tolerances.
NearTilePlan PlanNearTiles(const LightStack& stack, const NearLightOptions& options);

// Tile (tx, ty) of the plan as a stack of distant lights: the region cut from `stack`, each
// light replaced by the light seen from the tile's centre (no positions).
StatusOr<LightStack> NearTileStack(const LightStack& stack, const NearTilePlan& plan, int tx,
                                   int ty, int* x0 = nullptr, int* y0 = nullptr);

// Checks the lights' positions against the stack: every light has one or none does, each lies
// above the sample plane (z > 0) and off every texel. Names the first bad light.
Status CheckLightPositions(const LightStack& stack);

}  // namespace matfit
