// MaterialMaps: per-texel material parameters as SoA planes (one Image per quantity).
// Used for synthetic ground truth now and for fitted maps later. Absent maps are empty.
#pragma once

#include <string>

#include "core/image.h"

namespace matfit {

// Forward models of the CPU shading code (core/shading/shading.h); each is described by its
// ModelDescriptor (core/model/model.h), registered in this order in core/model/registry.cc.
// kMean predicts the per-texel mean colour (albedo plane) under every light.
enum class ShadingModel {
  kMean,
  kLambert,
  kBlinnPhong,
  kCookTorrance,
  kHeinrich,
  kPtm,
  kHsh,
  kLafortune,
  kRbf
};
// "mean", "lambert", "blinn-phong", "cook-torrance", "heinrich", "ptm", "hsh", "lafortune", "rbf"
const char* ShadingModelName(ShadingModel m);

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
  Image translucency;  // 3 planes: leaf translucency ρ_t (back-lit transmission factor); a
                       // material with it is two-sided (EvaluateLeafTexel)
  Image albedo_back;   // 3 planes: leaf lower-side diffuse albedo (empty: same as albedo)
  Image hl2;           // 3 planes: HL2 translucency coefficients h_1..h_3 for light from
                       // behind (empty: diffuse BTDF fallback)
  Image mask;          // 1 plane: 1 = sample, 0 = background
  // Seed method A (METHODS.md §2): albedo holds the mean texture t_c, normal the unit normal.
  Image ambient;                      // 3 planes: ambient factor a_c (grey for the seed fit)
  Image normal_scale;                 // 1 plane: |n| of the fitted, unnormalised normal
  Image specular_color;               // 3 planes: L_spec,c (residual of the θl = θv = 0 sample)
  bool specular_flat_normal = false;  // n_s = (0,0,1) in the specular term (improved variant)
  // Relighting bases (METHODS.md §4): k = basis_terms coefficients per channel, plane c·k + j
  // (3 channels, or 1 for grey stacks). HSH order = √k.
  Image coefficients;
  int basis_terms = 0;
  // The basis sum is sRGB-encoded, as RTI tools fit the stored 8-bit codes: R = decode(clamp(
  // Σ_j a_j B_j(l), 0, 1)) with the sRGB decode (ptm-srgb, hsh*-srgb; METHODS.md §4).
  bool basis_srgb = false;
  // rbf: the k = basis_terms basis functions of the light tabulated on a G × G grid (k planes,
  // core/shading/relight_basis.h RbfTableBasis); not texel-sized. Empty for ptm/hsh.
  Image basis_table;
  // 1 plane (rbf): the leave-one-light-out RMS of the texel's prediction, linear radiance per unit
  // light — how far an interpolating model can be off between its samples, which its residuals at
  // the samples do not show; fit/confidence.h floors the residual RMS with it. Empty: none.
  Image interpolation_error;
  // Lafortune lobes: amplitude ρ_s,j in `specular` (one plane per lobe); shape per lobe in
  // `lobe_shape` (planes 2j = C_xy, 2j + 1 = exponent).
  Image lobe_shape;
};

// The maps of the region [x, x + w) × [y, y + h): texel-sized planes cut, the rbf basis table
// (not texel-sized) kept, any plane of another size dropped. The region must lie inside the
// maps.
MaterialMaps CropMaps(const MaterialMaps& maps, int x, int y, int w, int h);

// Copies tile's texel-sized planes into the region of `into` at (x, y) (the inverse of CropMaps);
// a plane `into` lacks, or holds at another size, is allocated (zero) at its full size first. The
// region must lie inside.
void PasteMaps(const MaterialMaps& tile, int x, int y, MaterialMaps* into);

}  // namespace matfit
