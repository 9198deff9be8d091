// A synthetic leaf scan with ground truth: the core/synth "leaf" material laid on a white sheet
// with four black square markers, photographed under the 12 ring lights of the shared leaf rig
// (45° elevation, azimuth 225° − 30°·(k−1)) with near-light fall-off, and in front of
// several back lights of different position and exposure. Lambertian upper side; the back-lit
// photo is the back light times the leaf's transmission ρ_t. Compute only.
#pragma once

#include <cstdint>

#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "leaf/scan.h"

namespace matfit::leaf {

struct SyntheticScanOptions {
  int width = 192, height = 144;  // sheet, pixels
  int leaf_size = 112;            // the leaf material's square, pixels
  int back_images = 3;
  double mm_per_pixel = 0.2;
  double marker_mm = 4.0;  // side of the square markers
  bool minimal = false;    // one front-lit photo (light overhead) instead of the ring
  bool two_rings = false;  // lights alternately at 30° and 60° elevation (a lobe can be fitted)
  bool displacement = false;  // also registered displacement scans of both sides (mm)
  bool quantize = true;       // round every image to 8-bit sRGB codes, as files would be
  uint64_t seed = 7;
  bool Check(std::string* why) const;
};

struct SyntheticScan {
  LeafScan scan;       // images + lights; manifest fields (scale, max thickness) set
  MaterialMaps truth;  // sheet-sized: albedo, normal, translucency, thickness, mask (leaf)
  int leaf_x0 = 0, leaf_y0 = 0;
};

// `progress` (optional, display only) counts rendered images (top-lit, then back-lit).
SyntheticScan MakeSyntheticScan(const SyntheticScanOptions& options,
                                const ProgressFn& progress = {});

// Writes the scan as files: top_lights.lp + NN_TL.png (or front.png), NN_BL.png, leaf.json, and
// truth/{albedo,normal,translucency,thickness}.exr + truth/mask.png. Atomic (temporary folder).
// `progress` (optional, display only) counts written files.
Status WriteLeafScan(const SyntheticScan& s, const std::string& dir, bool overwrite,
                     const ProgressFn& progress = {});

}  // namespace matfit::leaf
