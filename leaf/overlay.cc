#include "leaf/overlay.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace matfit::leaf {

bool DigitCell(int digit, int x, int y) {
  // Rows top to bottom, 3 bits each (bit 2 = left column).
  static constexpr unsigned char kGlyphs[10][5] = {
      {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
      {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
  if (digit < 0 || digit > 9 || x < 0 || x > 2 || y < 0 || y > 4) return false;
  return (kGlyphs[digit][y] >> (2 - x)) & 1;
}

NumberLayout LayoutNumber(int number, double cx, double cy, int scale) {
  NumberLayout l;
  l.scale = std::max(1, scale);
  l.digits = int(std::to_string(std::max(0, number)).size());
  const int w = (4 * l.digits - 1) * l.scale, h = 5 * l.scale;
  // Pixel centres at integers: a span of w pixels is centred on cx when it starts at
  // cx − (w − 1)/2.
  l.x0 = int(std::lround(cx - (w - 1) / 2.0)), l.y0 = int(std::lround(cy - (h - 1) / 2.0));
  return l;
}

void DrawNumber(Image* img, int number, double cx, double cy, int scale) {
  const std::string text = std::to_string(std::max(0, number));
  const NumberLayout l = LayoutNumber(number, cx, cy, scale);
  const int s = l.scale, w = (4 * l.digits - 1) * s, h = 5 * s;
  auto put = [&](int x, int y, float v) {
    if (x < 0 || y < 0 || x >= img->width() || y >= img->height()) return;
    for (int c = 0; c < std::min(3, img->channels()); ++c) img->At(c, y, x) = v;
  };
  for (int y = l.y0 - s; y < l.y0 + h + s; ++y)
    for (int x = l.x0 - s; x < l.x0 + w + s; ++x) put(x, y, 0.0f);
  for (int k = 0; k < l.digits; ++k)
    for (int gy = 0; gy < 5; ++gy)
      for (int gx = 0; gx < 3; ++gx)
        if (DigitCell(text[size_t(k)] - '0', gx, gy))
          for (int y = 0; y < s; ++y)
            for (int x = 0; x < s; ++x) put(l.x0 + (4 * k + gx) * s + x, l.y0 + gy * s + y, 1.0f);
}

int NumberScale(int sheet_w, int sheet_h, int box_w, int box_h, int digits) {
  const int want = std::max(1, int(std::lround(std::min(sheet_w, sheet_h) / 100.0)));
  // The numeral and its box (4·digits + 1 by 7 cells) within the leaf's bounding box.
  const int fit = std::min(box_w / (4 * digits + 1), box_h / 7);
  return std::max(1, std::min(want, fit));
}

Image SegmentationOverlay(const SheetAnalysis& a) {
  const auto& s = a.segmentation;
  Image vis(a.width, a.height, 3);
  int max_label = 0;
  for (const auto& c : s.components) max_label = std::max(max_label, c.label);
  std::vector<const Component*> by_label(size_t(max_label) + 1, nullptr);
  for (const auto& c : s.components) by_label[size_t(c.label)] = &c;
  for (int64_t i = 0; i < vis.plane_size(); ++i) {
    const int l = s.labels[size_t(i)];
    float col[3];
    const float t = 0.5f * std::min(1.0f, a.luminance.Plane(0)[i]);
    col[0] = col[1] = col[2] = t;
    if (l > 0 && l <= max_label && by_label[size_t(l)]) {
      const Component& c = *by_label[size_t(l)];
      switch (c.kind) {
        case ComponentKind::kLeaf: {  // a hue per leaf (golden-ratio steps)
          const float hue = float(c.id * 0.618034 - std::floor(c.id * 0.618034));
          for (int k = 0; k < 3; ++k)
            col[k] = 0.35f + 0.6f * std::max(0.0f, 1 - std::abs(std::fmod(hue * 3 + k, 3.0f) - 1));
          break;
        }
        case ComponentKind::kTwig: col[0] = col[1] = col[2] = 1; break;
        case ComponentKind::kMarker: col[0] = col[1] = 0.1f, col[2] = 1; break;
        case ComponentKind::kSpeck: col[0] = col[1] = 1, col[2] = 0; break;
      }
    }
    for (int k = 0; k < 3; ++k) vis.Plane(k)[i] = col[k];
  }
  for (const auto& c : s.components)
    if (c.kind == ComponentKind::kLeaf) {
      const int digits = int(std::to_string(c.id).size());
      DrawNumber(&vis, c.id, c.cx, c.cy,
                 NumberScale(a.width, a.height, c.x1 - c.x0 + 1, c.y1 - c.y0 + 1, digits));
    }
  return vis;
}

}  // namespace matfit::leaf
