// HSH `.rti` files (the RTIBuilder / RTIViewer "#HSH1.2" format) from an hsh fit of order 2 or
// 3. Compute only: the bytes of the file; the pack writer stores them.
#pragma once

#include <string>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

// The hemispherical-harmonics basis as RTI tools evaluate it, c = cos θ, φ = atan2(l_y, l_x):
//   w0 = 1/√(2π), w1 = √(6/π) cos φ √(c − c²), w2 = √(3/(2π)) (2c − 1), w3 = √(6/π) sin φ √(c −
//   c²), w4 = √(30/π) cos 2φ (c² − c), w5 = √(30/π) cos φ (2c − 1) √(c − c²), w6 = √(5/(2π)) (1 −
//   6c + 6c²), w7 = √(30/π) sin φ (2c − 1) √(c − c²), w8 = √(30/π) sin 2φ (c² − c).
// The same functions as matfit's HshBasis (core/shading/relight_basis.h) up to order within a
// band (RTI: m from +l down to −l; matfit: m ascending) and sign; EncodeRti maps between them.
void RtiHshBasis(int terms, double lx, double ly, double lz, double* out);

// RTI term i (of 4 or 9) = sign[i] × matfit HshBasis term from[i]; checked numerically.
Status RtiHshTermMap(int terms, int* from, double* sign);

// The file's bytes: a "#HSH1.2" comment line, then the lines "3" (HSH), "W H 3" (bands),
// "terms 2 1" (terms, basis type, bytes per coefficient), then binary little-endian float32
// scale[terms] and bias[terms], then per row (the BOTTOM row first), per texel, per band (r, g,
// b), per term one byte: coefficient = byte / 255 × scale_j + bias_j, so that a band's value
// is Σ_j coefficient_j w_j(l) in display units (the fit's value: sRGB-encoded for hsh*-srgb,
// linear radiance for hsh2/hsh3). A grey fit is written with three equal bands. Refused for
// anything but an hsh fit of 4 or 9 terms and 1 or 3 channels.
StatusOr<std::string> EncodeRti(const MaterialMaps& maps);

}  // namespace matfit
