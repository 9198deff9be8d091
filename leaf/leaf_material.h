// One leaf of a scanned sheet as a two-sided leaf material (METHODS.md §5–§6): upper-side
// albedo and normal (robust photometric stereo on the flat-fielded top-lit images), fused
// translucency, thickness (displacement maps, else a Beer–Lambert estimate), the 2005 derived
// maps, default or fitted specular, and the multipole → HL2 translucency precompute.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "core/status.h"
#include "leaf/hl2_error.h"
#include "leaf/scan.h"
#include "leaf/segment.h"
#include "leaf/sheet.h"
#include "leaf/translucency.h"

namespace matfit::leaf {

// Per-texel status codes of leaf packs (status.png), beside fit/fit_types.h's 0–6.
enum LeafTexelStatus : uint8_t {
  kLeafTexelThin = 20,  // thinner than the multipole model's validity: clamped (METHODS.md §5)
};

struct LeafMaterialOptions {
  TranslucencyOptions translucency;
  bool reference_precompute = false;       // the direct method instead of the fast one
  double default_max_thickness_mm = 0.25;  // Beer–Lambert estimate scale when none is given
  double sheet_albedo = 1.0;               // albedo of the bare sheet (albedo maps are relative)
  // Leaf default specular when the top-lit lights cannot constrain a lobe (METHODS.md §5:
  // Cook–Torrance; leaf cuticle IOR ≈ 1.45 → F0 ≈ 0.034; roughness in the range 0.3–0.6).
  double default_f0 = 0.034, default_roughness = 0.45;
  int margin_px = 2;                // crop margin around the leaf's bounding box
  bool report_hl2_error = true;     // HL2 vs multipole error at π/2, π/4, π/8 (report.json)
  int64_t hl2_error_texels = 4096;  // ... on at most this many leaf texels (0 = all)
  bool Check(std::string* why) const;
};

struct LeafMaterial {
  Component component;
  int crop_x = 0, crop_y = 0;  // crop origin in the sheet, pixels
  double mm_per_texel = 0;
  MaterialMaps maps;            // Cook–Torrance upper side + leaf maps + mask
  std::vector<uint8_t> status;  // per texel: 0 ok, 1 outside the leaf, fit and leaf codes
  // The 2005 work's derived maps (METHODS.md §6), each 1 plane in [0, 1].
  Image thickness_variation;        // inverted transmission luminance
  Image absorption;                 // absorption modulation A(x) from −ln(transmission)
  Image bump;                       // high-passed upper-side luminance (artist bump map)
  bool thickness_estimated = true;  // Beer–Lambert estimate (no displacement maps)
  bool specular_fitted = false;     // else the leaf default
  TranslucencyResult translucency;
  std::array<Hl2ErrorStats, 3> hl2_error;  // at elevations π/2, π/4, π/8 (when reported)
  double seconds_maps = 0, seconds_translucency = 0, seconds_hl2_error = 0;
  std::vector<std::string> warnings;
};

// `mm_per_pixel` > 0 (the caller decides the scale, default included). `progress` (optional)
// counts kLeafMaterialSteps: photometric stereo, the other maps, translucency, HL2 error.
inline constexpr int kLeafMaterialSteps = 4;
StatusOr<LeafMaterial> MakeLeafMaterial(const LeafScan& scan, const SheetAnalysis& sheet,
                                        const Component& leaf, double mm_per_pixel,
                                        const LeafMaterialOptions& options,
                                        const ProgressFn& progress = {});

}  // namespace matfit::leaf
