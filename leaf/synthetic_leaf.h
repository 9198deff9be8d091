// Synthetic leaf for the translucency tests and benchmarks: the core/synth "leaf" material
// (veined blade, thickness 0.2–0.5 mm) as transport inputs, with its horizon map.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"
#include "leaf/translucency.h"

namespace matfit::leaf {

struct SyntheticLeaf {
  Image rho, thickness, normal, height_mm, horizon;
  std::vector<uint8_t> mask;
  TransportInput input;  // points into this object: do not copy or move it after making it
};

// size² texels at `mm_per_texel`; `relief` scales the height field (and so the normals' tilt
// and the self-shadowing) of the material.
void MakeSyntheticLeaf(int size, double mm_per_texel, double relief, SyntheticLeaf* out);

}  // namespace matfit::leaf
