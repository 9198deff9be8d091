// Geometric operations on a LightStack: crop and box downsampling (mip levels). Pure
// computation; lights, view, provenance and clip records are kept.
#pragma once

#include "core/light_stack.h"
#include "core/status.h"

namespace matfit {

// Copies what describes the stack but not its samples or size — lights, view, physical size,
// near frame, band, provenance, per-image decode records (not read_warnings), mask source,
// source size and crop — from `from` to `to` (the mask is the caller's: its size is the stack's).
void CopyStackMetadata(const LightStack& from, LightStack* to);

// The stack restricted to the rectangle [x, x + w) × [y, y + h) (must lie inside); samples are
// copied as stored (same sample type and table).
StatusOr<LightStack> CropStack(const LightStack& stack, int x, int y, int w, int h);

// Box filter over factor × factor blocks (factor ≥ 1; trailing rows/columns that do not fill a
// block are dropped): the radiance a renderer sees when a texel covers 1/factor² of a pixel.
// A block is inside the mask when at least half of its texels are, and averages those only.
// Non-finite samples are skipped (NaN only when the whole block is); in a stack that may be
// clipped (integer files), a block holding a clipped sample is set to 1 (the clip code).
// mm_per_texel scales by the factor. The result is float32 (factor 1: a copy, as CropStack).
StatusOr<LightStack> DownsampleStack(const LightStack& stack, int factor);

// The float stack as 8-bit sRGB (bits 8) or 16-bit linear (bits 16) files would hold it, kept at
// that depth: codes are the clamped values rounded to nearest as WriteImage quantises them (NaN →
// 0), with the decoder's table, encodings and clip record (pixels with a channel at the maximum
// code). Tests and benchmarks make native-depth stacks with it.
LightStack QuantiseStack(const LightStack& stack, int bits);

// Bounding box of the mask (the whole stack when it has none), grown by `margin` texels.
void MaskBounds(const LightStack& stack, int margin, int* x, int* y, int* w, int* h);

}  // namespace matfit
