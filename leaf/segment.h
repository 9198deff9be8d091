// Leaf segmentation of a scanned sheet from its transmission image (back light / bare sheet):
// threshold → morphological opening → connected components, each classified as a leaf, a twig
// (long and thin), a marker (the square fiducials and reference patch: square, full, four
// corners, achromatic) or a speck (too small).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"

namespace matfit::leaf {

enum class ComponentKind { kLeaf, kTwig, kMarker, kSpeck };
const char* ComponentKindName(ComponentKind k);  // "leaf", "twig", "marker", "speck"

struct Component {
  ComponentKind kind = ComponentKind::kLeaf;
  int id = 0;                          // 1-based reading-order index among the leaves; 0 otherwise
  int label = 0;                       // value of its pixels in Segmentation::labels
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // bounding box, inclusive, pixels
  int64_t area_px = 0;
  double cx = 0, cy = 0;      // centroid, pixels
  double elongation = 1;      // long / short side of the minimum-area rectangle
  double rectangularity = 0;  // area / minimum-area rectangle area
  double side_px = 0;         // markers: mean side of the square
  int corners = 0;            // vertices of the simplified convex hull (4: a square)
  double chroma = -1;         // Σ(max − min) / Σ max of the colour photo's RGB; −1 = no photo
  bool touches_border = false;  // the component reaches the image edge (likely cut off)
};

struct SegmentOptions {
  double threshold = 0.5;              // transmission below this (background = 1) is sample
  int min_area_px = 40;                // smaller components are specks
  double twig_elongation = 4.0;        // minimum-area rectangle at least this elongated → twig
  double marker_rectangularity = 0.8;  // square and this full → marker
  double marker_max_aspect = 1.3;
  double marker_rectangularity_grey = 0.9;  // ... when there is no colour photo to test
  double marker_max_chroma = 0.3;  // markers are printed black and white; leaves are coloured
  int open_radius = 1;             // morphological opening radius, pixels
  bool Check(std::string* why) const;
};

struct Segmentation {
  int width = 0, height = 0;
  std::vector<int32_t> labels;        // per pixel: Component::label, 0 = background
  std::vector<Component> components;  // leaves first (by id), then twigs, markers, specks
  int leaves() const;
};

// `transmission`: 1 plane, ≈ 1 on the bare sheet, lower where something blocks the light.
// `color` (optional, 3 planes on the same grid, e.g. the mean top-lit photo): markers must be
// achromatic.
Segmentation Segment(const Image& transmission, const SegmentOptions& options,
                     const Image* color = nullptr);

}  // namespace matfit::leaf
