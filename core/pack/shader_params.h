// MaterialMaps packed for the shaders: every per-texel parameter the model's GLSL reads, as float
// planes in a fixed layout (plane q = component q % 4 of layer q / 4 of an RGBA32F 2D array).
// Packs store it as viewer/params.bin (little-endian float32, layers × height × width × 4), so
// the web viewer, the EGL renderer and the CPU renderer see exactly the same texels.
// Layout (render/shaders/material.frag reads the same indices):
//   0–2 unit normal, 3–5 albedo (mean texture for heinrich, preview for ptm/hsh), 6 mask;
//   blinn-phong: 7 k_s, 8 exponent;  cook-torrance: 7 F0, 8 roughness;
//   lafortune (L lobes): 7 + j amplitude, 7 + L + 2j C_xy, 8 + L + 2j exponent;
//   heinrich: 7–9 ambient, 10 |n_raw|, 11–13 L_spec, 14 exponent;
//   ptm/hsh/rbf: 7 + c·K + j coefficient j of channel c (rbf's basis is a separate table:
//   basis_table, K planes of table_size² floats, an R32F 2D array texture in the shaders);
//   two-sided leaves (translucency present), after the model's planes from leaf_base:
//   +0–2 ρ_t, +3–5 lower-side albedo, +6–8 HL2 h_1..h_3 (when leaf_hl2).
#pragma once

#include <vector>

#include "core/large_page_allocator.h"
#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

struct ShaderParams {
  int width = 0, height = 0, layers = 0;
  int model = 0;  // material.frag's u_model: ShadingModel order
  int terms = 0;  // ptm/hsh coefficients per channel, lafortune lobes
  int coef_channels = 3;
  bool heinrich_specular = false, flat_normal = false;
  bool basis_srgb = false;  // ptm/hsh: decode the basis sum from sRGB
  int leaf_base = -1;       // first leaf plane, −1: not a leaf
  bool leaf_hl2 = false;    // HL2 coefficients present (else the diffuse BTDF)
  // rbf: MaterialMaps::basis_table, terms planes of table_size × table_size (row j = y node j).
  int table_size = 0;
  std::vector<float> basis_table;
  // layers × height × width × 4, row 0 = top (huge pages: one fault per 2 MiB, not per 4 KiB)
  std::vector<float, LargePageAllocator<float>> texels;
};

// Fails, naming the missing map, when the model's maps are absent or the wrong size.
StatusOr<ShaderParams> PackShaderParams(const MaterialMaps& maps);
// The same checks without copying any texel (the CPU renderer's validation).
Status CheckShaderMaps(const MaterialMaps& maps);

}  // namespace matfit
