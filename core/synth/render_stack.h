// Renders a LightStack from material maps with the CPU shading functions (no I/O).
#pragma once

#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"

namespace matfit::synth {

// Reflectance factor of texel `index` (row-major) in channel c for light l and view v,
// without shadowing: ρ_d,c (n·l)⁺ + specular lobe of the material's model. The one place
// that maps MaterialMaps onto core/shading/shading.h.
float ShadeTexel(const MaterialMaps& m, int64_t index, int c, const Vec3f& l, const Vec3f& v);

// 1 where texel (x, y) sees the light over the height field (texel units), else 0: march
// toward the light in half-texel steps until the ray clears the highest point.
Image CastShadowVisibility(const Image& height, const Vec3& light);

struct RenderOptions {
  bool cast_shadows = false;  // apply CastShadowVisibility per light
  Vec3 view{0, 0, 1};         // view direction (unit)
};

// p_{i,c}(x) = I_{i,c} · V_i(x) · ShadeTexel(x, c, l_i, v). Parallel over images.
LightStack RenderStack(const MaterialMaps& m, const std::vector<LightSample>& lights,
                       const RenderOptions& options);

}  // namespace matfit::synth
