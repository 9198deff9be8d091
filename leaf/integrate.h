// Height field from a normal map (Frankot–Chellappa): the least-squares integrable surface,
// solved in the Fourier domain. Gradients p = −n_x/n_z (x right), q = −n_y/n_z (y up); outside
// the mask the surface is taken flat. Heights in texel units, mean zero over the mask.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"

namespace matfit::leaf {

Image HeightFromNormals(const Image& normal, const std::vector<uint8_t>& mask);

}  // namespace matfit::leaf
