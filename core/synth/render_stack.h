// Renders a LightStack from material maps with the CPU shading functions (no I/O).
#pragma once

#include "core/progress_fn.h"

#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"

namespace matfit::synth {

// 1 where texel (x, y) sees the light over the height field (texel units), else 0: march
// toward the light in half-texel steps until the ray clears the highest point.
Image CastShadowVisibility(const Image& height, const Vec3& light);

struct RenderOptions {
  bool cast_shadows = false;  // apply CastShadowVisibility per light
  Vec3 view{0, 0, 1};         // view direction (unit)
};

// p_{i,c}(x) = I_{i,c} · V_i(x) · EvaluateTexel(x, c, l_i, v). Parallel over images;
// `progress` (optional, display only) counts rendered images.
LightStack RenderStack(const MaterialMaps& m, const std::vector<LightSample>& lights,
                       const RenderOptions& options, const ProgressFn& progress = {});

}  // namespace matfit::synth
