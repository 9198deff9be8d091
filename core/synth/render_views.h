// Multi-view rendering of a material (issue 17): every view × light image rectified to the
// reference plane, as BTF measurements are (the Bonn and UTIA sets are resampled to a frontal
// grid). What one view cannot show appears here: parallax and masking by the height field,
// cast shadows from the point actually seen, and the model's own Fresnel and Smith terms at
// each view. Pure computation (no I/O).
#pragma once

#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"

namespace matfit::synth {

// What the camera along `view` sees at each texel of the reference plane: the first point of
// the height field (texel units, y up) that the ray toward (x, y, 0) meets coming from the
// camera — at image column x + s·v_x, row y − s·v_y and height s·v_z, the largest s with
// s·v_z ≤ h — and the material's maps there (bilinear, the normal renormalised).
struct ViewWarp {
  MaterialMaps maps;               // the maps at the seen points, reference-plane texels
  std::vector<float> col, row, z;  // the seen points (image column, row; height in texels)
};
ViewWarp WarpToView(const MaterialMaps& m, const Vec3& view);

// 1 when the point (column, row, height z) sees the light over the height field `h` (whose
// largest value is hmax): a march toward the light in half-texel steps until it clears hmax or
// leaves the frame.
bool PointSeesLight(const Image& h, float hmax, double col, double row, double z, const Vec3& l);

// Every view × light: images ordered view by view, each view's lights in `lights` order, each
// image's LightSample carrying its view (has_view). cast_shadows: a light hidden from the seen
// point by the height field contributes 0. `progress` counts views.
LightStack RenderViews(const MaterialMaps& m, const std::vector<LightSample>& lights,
                       const std::vector<Vec3>& views, bool cast_shadows,
                       const ProgressFn& progress = {});

}  // namespace matfit::synth
