// The texels the stack diagnosis samples (fit/diagnostics.h: the tone-curve estimate), and
// their codes taken while the images are decoded: a gather across every plane of a decoded
// stack costs a cache miss per sampled row of each plane (~0.04 s of CPU for 240 images of
// 512 × 344), while each image is still in cache right after its decode.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace matfit {

inline constexpr int kProbeTexels = 2048;  // DiagnoseStack's default sample

// About max_texels texels on a regular grid of a width × full_height stack: every `step`-th
// column and row from step / 2, step = max(1, ⌊√(width · full_height / max_texels)⌋). `ys` are
// the grid's rows inside the band [band_row0, band_row0 + band_rows), relative to band_row0.
struct ProbeGrid {
  int step = 1;
  std::vector<int> xs, ys;
  bool operator==(const ProbeGrid&) const = default;
};
ProbeGrid MakeProbeGrid(int width, int full_height, int band_row0, int band_rows, int max_texels);

// An integer stack's codes at a grid's texels, [row ys[r]][image i][channel c][column xs[k]]
// at codes[((r · images + i) · channels + c) · xs.size() + k].
struct StackProbe {
  ProbeGrid grid;
  int images = 0, channels = 0;
  std::vector<uint16_t> codes;

  StackProbe(ProbeGrid g, int num_images, int num_channels);
  uint16_t Code(int r, int i, int c, int k) const {
    return codes[((std::size_t(r) * images + i) * channels + c) * grid.xs.size() + k];
  }
  // Takes image i's codes from its planes (planes[c]: rows of `width` codes, the band's rows;
  // channels ≤ 4).
  template <typename T>
  void Take(int i, const T* const* planes, int width);
};

}  // namespace matfit
