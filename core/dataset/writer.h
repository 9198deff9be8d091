// Writes a LightStack as a dataset folder in any layout the readers accept.
#pragma once

#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/progress_fn.h"

namespace matfit {

struct DatasetWriteOptions {
  Layout layout = Layout::kLp;
  // 8: 8-bit sRGB PNG (quantised, like camera JPEG/PNG data); 16: 16-bit linear PNG;
  // 32: float EXR (lossless).
  int bits = 16;
  // Base name of the images for the lights-txt layout (must equal the final folder name).
  std::string object_name = "object";
  // Image file format: "auto" (PNG for 8/16-bit, EXR for 32), "png" (8/16-bit), "jpg" (8-bit
  // sRGB JPEG, lossy, like camera RTI sets) or "exr" (32-bit). Last, so that aggregate
  // initialisers {layout, bits, object_name} keep their meaning.
  std::string format = "auto";

  bool Check(std::string* why) const;
};

// Writes into the existing folder `dir`. Bonn needs every light at integer degrees.
// `progress` (optional, display only) counts written images.
// light_positions.txt (docs/formats.md, "Near lights"): a comment naming the frame, the count,
// then x y z per light in source pixels. WriteDataset writes it for stacks with positions.
std::string FormatLightPositions(const std::vector<Vec3>& positions);

Status WriteDataset(const LightStack& stack, const DatasetWriteOptions& options,
                    const std::string& dir, const ProgressFn& progress = {});

}  // namespace matfit
