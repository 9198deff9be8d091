// The segmentation picture (segmentation.png of a leaf job): leaves in distinct hues, twigs
// white, markers blue, specks yellow, over the dimmed transmission, and every leaf labelled with
// its number (the `id` of leaves.json and of its pack folder leaf_NN) in a white 3 × 5 pixel-font
// numeral on a black box at its centroid, so a user can tell which pack is which leaf.
#pragma once

#include "core/image.h"
#include "leaf/sheet.h"

namespace matfit::leaf {

// Whether cell (x, y), x in [0, 3), y in [0, 5) from the top, of digit d's glyph is lit.
bool DigitCell(int digit, int x, int y);

// Where DrawNumber puts `number`: cells of `scale` pixels; glyph k's top-left at
// (x0 + k · 4 · scale, y0); the black box spans one cell more on every side.
struct NumberLayout {
  int x0 = 0, y0 = 0, scale = 1, digits = 1;
};
NumberLayout LayoutNumber(int number, double cx, double cy, int scale);

// Draws `number` centred on (cx, cy) into the first three planes of `img` (clipped to it).
void DrawNumber(Image* img, int number, double cx, double cy, int scale);

// The numeral scale for a leaf of this bounding box in a sheet of this size: about 1/100 of
// the sheet's short side, at least 1, and small enough for the numeral to fit the leaf's box.
int NumberScale(int sheet_w, int sheet_h, int box_w, int box_h, int digits);

Image SegmentationOverlay(const SheetAnalysis& a);

}  // namespace matfit::leaf
