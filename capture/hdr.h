// Exposure brackets → linear radiance (compute only, no I/O).
//   E(x) = Σ_i w_i(x) (f_i(x) − d_i(x)) / t_i  /  Σ_i w_i(x),   w_i = t_i · hat(f_i)
// with f_i the raw frame (full-scale units), d_i the dark frame at the same exposure, t_i the
// exposure in seconds, and hat(f) = min(f − low, high − f) on (low, high), 0 outside: clipped
// and near-black samples get no weight, and longer exposures (less relative noise) more. A
// pixel with no usable sample takes the shortest exposure if it saturated there (flagged), else
// the longest.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"

namespace matfit::capture {

struct Bracket {
  const Image* frame = nullptr;
  const Image* dark = nullptr;  // may be null (no dark subtraction)
  double exposure_s = 0;
};

struct HdrOptions {
  double low = 0.01, high = 0.95;  // usable raw range
};

// All frames share size and channels. saturated_pixels counts pixels with a channel clipped at
// every exposure.
Image MergeBrackets(const std::vector<Bracket>& brackets, const HdrOptions& o,
                    int64_t* saturated_pixels);

// Divides by a flat field normalised to mean 1 over its pixels (grey flat: every channel).
void ApplyFlatField(const Image& flat, Image* img);
// Mean-1 normalisation of a flat frame.
Image NormaliseFlat(const Image& flat);

}  // namespace matfit::capture
