// PTM files (Malzbender & Gelb, "Polynomial Texture Map (.ptm) File Format", HP Labs, v1.2) from
// a ptm fit: the format RTIViewer and the RTI web viewers open. Compute only: the bytes of the
// file; the pack writer stores them.
#pragma once

#include <string>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

enum class PtmFormat {
  kRgb,   // PTM_FORMAT_RGB: a polynomial per colour channel (exactly the fit, quantised)
  kLrgb,  // PTM_FORMAT_LRGB: one luminance polynomial and an RGB colour per texel
};

// The file's bytes. Polynomial C(l) = a0 u² + a1 v² + a2 uv + a3 u + a4 v + a5, (u, v) = (l_x,
// l_y) in the tangent frame (x right, y up), in 8-bit code units: C = 255 × the fit's value
// (sRGB-encoded for ptm-srgb, as RTI tools fit; linear radiance for ptm). a_j = (byte − bias_j)
// × scale_j, one scale and bias per term over every texel and channel (the range includes 0).
// Rows are stored bottom to top. RGB: the red block, the green block, then the blue block, each
// six bytes per texel. LRGB: six luminance bytes per texel, then three colour bytes per texel;
// C_c = L(l) × rgb_c / 255 with L the least-squares common polynomial of the channels (exact
// when a texel's channels are proportional, the chroma constant over lights). A grey fit is
// written with r = g = b. Refused for anything but a 6-term ptm of 1 or 3 channels.
StatusOr<std::string> EncodePtm(const MaterialMaps& maps, PtmFormat format);

}  // namespace matfit
