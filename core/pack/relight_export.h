// The relight / OpenLIME web layout ("relight" format of cnr-isti-vclab's relight-cli, read by
// OpenLIME's LayerRTI with the "image" layout and by relight's own tools) from a ptm or hsh fit.
// Compute only: info.json's text and the plane images; the pack writer stores them.
#pragma once

#include <string>
#include <vector>

#include "core/image.h"
#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

// The light weights of the layout's bases, (l_x, l_y, l_z) in the tangent frame (x right, y up):
//   ptm: 1, x, y, x², xy, y² (relight's order: by degree, then by the power of y);
//   hsh: RtiHshBasis (core/pack/rti_export.h), 4 or 9 terms.
void RelightPtmBasis(double lx, double ly, double* out);

struct RelightWeb {
  std::string info_json;  // info.json
  // plane_<i>.jpg, i = 0 … ⌈nplanes / 3⌉ − 1, as RGB images of codes / 255 (exact multiples, so
  // an 8-bit writer stores the codes). Row 0 is the top row, as in the pack's maps.
  std::vector<Image> planes;
};

// Colour space "rgb": plane p = 3·j + c holds term j of channel c (r, g, b), so image i holds
// term i of the three channels. A coefficient is (code / 255 − bias_p) × scale_p with one scale
// and bias per plane (the min … max of that plane over the texels), and a channel's value is
// Σ_j coefficient_j w_j(l) in display units [0, 1] (the fit's value: sRGB-encoded for *-srgb
// fits, linear radiance otherwise). A grey fit is written with three equal channels. Refused for
// anything but a 6-term ptm or a 4- or 9-term hsh of 1 or 3 channels.
StatusOr<RelightWeb> EncodeRelightWeb(const MaterialMaps& maps);

}  // namespace matfit
