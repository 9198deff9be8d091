// MaterialMaps: per-texel material parameters as SoA planes (one Image per quantity).
// Used for synthetic ground truth now and for fitted maps later. Absent maps are empty.
#pragma once

#include <string>

#include "core/image.h"

namespace matfit {

// Forward models of the CPU shading code (core/shading/shading.h).
enum class ShadingModel { kLambert, kBlinnPhong, kCookTorrance };
const char* ShadingModelName(ShadingModel m);  // "lambert", "blinn-phong", "cook-torrance"

struct MaterialMaps {
  int width = 0, height = 0;
  ShadingModel model = ShadingModel::kLambert;
  Image normal;        // 3 planes: unit normal (x right, y up, z out of the surface)
  Image albedo;        // 3 planes: linear diffuse albedo ρ_d in [0, 1]
  Image height_map;    // 1 plane: height in texel units (for self-shadowing)
  Image specular;      // 1 plane: Blinn–Phong k_s, or Cook–Torrance F0
  Image exponent;      // 1 plane: Blinn–Phong exponent e
  Image roughness;     // 1 plane: Cook–Torrance perceptual roughness r (GGX α = r²)
  Image thickness;     // 1 plane: leaf thickness in mm
  Image translucency;  // 3 planes: leaf translucency ρ_t (back-lit transmission factor)
  Image mask;          // 1 plane: 1 = sample, 0 = background
};

}  // namespace matfit
