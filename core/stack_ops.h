// Geometric operations on a LightStack: crop and box downsampling (mip levels). Pure
// computation; lights, view, provenance and clip records are kept.
#pragma once

#include "core/light_stack.h"
#include "core/status.h"

namespace matfit {

// The stack restricted to the rectangle [x, x + w) × [y, y + h) (must lie inside).
StatusOr<LightStack> CropStack(const LightStack& stack, int x, int y, int w, int h);

// Box filter over factor × factor blocks (factor ≥ 1; trailing rows/columns that do not fill a
// block are dropped): the radiance a renderer sees when a texel covers 1/factor² of a pixel.
// A block is inside the mask when at least half of its texels are, and averages those only.
// Non-finite samples are skipped (NaN only when the whole block is); in a stack that may be
// clipped (integer files), a block holding a clipped sample is set to 1 (the clip code).
// mm_per_texel scales by the factor.
StatusOr<LightStack> DownsampleStack(const LightStack& stack, int factor);

// Bounding box of the mask (the whole stack when it has none), grown by `margin` texels.
void MaskBounds(const LightStack& stack, int margin, int* x, int* y, int* w, int* h);

}  // namespace matfit
