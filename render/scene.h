// Per-pixel scene geometry of the previews, the CPU twin of material.frag's main(): an
// orthographic camera looking down −z at a sample plane filling the view, at a unit sphere
// (texture: longitude φ ∈ [−π/2, π/2] across u, latitude down v, one copy over the front), or
// at a draped cloth: the height field z = ClothHeight(x, y) over [−1, 1]², seen from above, so
// each pixel hits it at its own (x, y); texture as on the plane.
#pragma once

#include "core/vec3.h"
#include "render/render_options.h"

namespace matfit::render {

struct SceneHit {
  bool hit = false;
  int tx = 0, ty = 0;                        // texel (ty = row from the top)
  Vec3f t{1, 0, 0}, b{0, 1, 0}, n{0, 0, 1};  // tangent frame in world coordinates
};

// Pixel (px, py), py = row from the top, of a size × size image; material width × height.
// The orthographic ray through the pixel starts at x r + y u + 3 v (x, y ∈ [−1, 1]) and runs
// along −v: the plane z = 0 and the cloth are clipped to [−1, 1]², the cloth is found by 128
// march steps and 20 bisections.
SceneHit HitScene(Scene scene, const CameraFrame& camera, int size, int px, int py, int width,
                  int height);

// The cloth's folds (dimensionless, x, y ∈ [−1, 1]) and their gradient (∂z/∂x, ∂z/∂y).
float ClothHeight(float x, float y, float* dzdx, float* dzdy);

// material.frag's display transform: exposure, tone map, clamp to [0, 1], sRGB encode.
float DisplayEncode(float linear, const RenderOptions& o);

}  // namespace matfit::render
