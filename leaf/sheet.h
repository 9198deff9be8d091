// Whole-sheet analysis of a leaf scan: flat-field the back-lit images by the unobstructed back
// light and fuse them into one transmission image, segment it, and flat-field the top-lit
// images by the bare sheet's brightness (the near-light fall-off), all estimated from the
// background around the leaves. Compute only (no I/O).
#pragma once

#include <string>
#include <vector>

#include "core/image.h"
#include "core/light_stack.h"
#include "core/progress_fn.h"
#include "core/status.h"
#include "leaf/flat_field.h"
#include "leaf/scan.h"
#include "leaf/segment.h"

namespace matfit::leaf {

struct SheetOptions {
  SegmentOptions segment;
  BackgroundOptions background;
  int back_margin_px = 3;  // sample pixels grown by this before taking the background (back light)
  int top_margin_px = 6;   // ... for the top-lit images (cast shadows around the leaves)
  double saturation = 0.995;  // linear values at or above this are clipped and not used
  bool Check(std::string* why) const;
};

struct SheetAnalysis {
  int width = 0, height = 0;
  Image transmission;  // 3 planes: fused back-lit transmission ρ_t (bare sheet = 1)
  Image luminance;     // 1 plane: its Rec. 709 luminance
  Segmentation segmentation;
  std::vector<uint8_t> background;  // bare-sheet pixels the fits used
  // Top-lit images flat-fielded: J_m = I_m / B_m · cos θ_m, so a Lambertian texel of albedo ρ
  // relative to the sheet reads ρ (n·l_m) (kept below 1); clipped samples read exactly 1.
  // Same lights (and clipping counts) as the scan.
  LightStack top;
  Image front;              // minimal case: front-lit photo / its background (sheet = 1)
  double back_rms_log = 0;  // worst background-fit RMS of log I over the back-lit images
  double top_rms_log = 0;   // ... over the top-lit images
  int saturated_back_samples = 0;
  std::vector<std::string> warnings;
};

// `progress` (optional) counts the passes: segmentation, two fusion rounds, each top-lit image.
StatusOr<SheetAnalysis> AnalyzeSheet(const LeafScan& scan, const SheetOptions& options,
                                     const ProgressFn& progress = {});
// The same, moving the scan's top-lit stack into the analysis instead of copying it (large
// scans: the stack is the biggest buffer); scan->top is left empty.
StatusOr<SheetAnalysis> AnalyzeSheet(LeafScan* scan, const SheetOptions& options,
                                     const ProgressFn& progress = {});

// Rec. 709 luminance of a 3-plane image (a 1-plane image is returned as is).
Image Luminance(const Image& rgb);

}  // namespace matfit::leaf
