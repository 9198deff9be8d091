// A leaf scan (METHODS.md §5–§6): what a leaf rig delivers, decoded to linear float images on
// one pixel grid. Described by a small JSON manifest (docs/formats.md, "Leaf scans").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/image.h"
#include "core/light_stack.h"
#include "core/status.h"

namespace matfit::leaf {

struct LeafScan {
  std::string source;  // folder
  LightStack top;      // top-lit images with light directions (empty: minimal case)
  Image front;         // minimal case: one front-lit photo (used when `top` is empty)
  std::string front_file;
  std::vector<Image> back;  // back-lit (transmission) images, ≥ 1
  std::vector<std::string> back_files;
  // Optional per-side scans on the same grid (empty when absent).
  // lower_normal is in the lower side's own frame (x' = x, y' = −y, z' out of the lower
  // surface), registered to the upper side's pixel grid.
  Image upper_albedo, lower_albedo, upper_normal, lower_normal, upper_displacement,
      lower_displacement;
  double displacement_scale_mm = 1.0;  // mm per unit of the displacement maps
  // Scale: mm per pixel when known, else the physical side of the square markers (mm).
  double mm_per_pixel = 0, marker_size_mm = 0;
  double max_thickness_mm = 0;  // measured maximum leaf thickness; 0 = unknown
  std::vector<std::string> warnings;

  int width() const { return back.empty() ? 0 : back[0].width(); }
  int height() const { return back.empty() ? 0 : back[0].height(); }
};

struct LeafScanReadOptions {
  std::string manifest;  // empty: DIR/leaf.json when present, else detection
  bool confine = false;  // refuse any file that resolves outside the scan folder (the server)
  // Images × width × height × channels over every image of the scan, from the headers before a
  // pixel is decoded (a decompression bomb is refused, not allocated); 0 = no limit.
  int64_t max_samples = 0;
  // Check only (the server's submission check): files, manifest and headers; no pixel decoded,
  // the scan returned holds no images.
  bool headers_only = false;
  // Only this region of every image of the scan (--crop); it must lie inside them.
  std::optional<CropRect> crop;
};

// Reads a leaf-scan folder. No manifest: DIR/leaf.json when present, else detection
// (one `.lp` file = top-lit images; `*_BL.*` / `*back*` images = back-lit; `*_FL.*` /
// `*front*` = a single front-lit photo). Errors name the file or manifest field at fault.
StatusOr<LeafScan> ReadLeafScan(const std::string& dir, const LeafScanReadOptions& options);
// confine: refuse any file that resolves outside `dir` (the server).
StatusOr<LeafScan> ReadLeafScan(const std::string& dir, const std::string& manifest = "",
                                bool confine = false);

}  // namespace matfit::leaf
