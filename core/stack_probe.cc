#include "core/stack_probe.h"

#include <algorithm>
#include <cmath>

namespace matfit {

ProbeGrid MakeProbeGrid(int width, int full_height, int band_row0, int band_rows, int max_texels) {
  ProbeGrid g;
  const double texels = double(width) * full_height;
  g.step = std::max(1, int(std::sqrt(texels / std::max(1, max_texels))));
  for (int x = g.step / 2; x < width; x += g.step) g.xs.push_back(x);
  for (int y = g.step / 2; y < full_height; y += g.step)
    if (y >= band_row0 && y < band_row0 + band_rows) g.ys.push_back(y - band_row0);
  return g;
}

StackProbe::StackProbe(ProbeGrid g, int num_images, int num_channels)
    : grid(std::move(g)), images(num_images), channels(num_channels) {
  codes.assign(grid.ys.size() * size_t(images) * size_t(channels) * grid.xs.size(), 0);
}

template <typename T>
void StackProbe::Take(int i, const T* const* planes, int width) {
  const size_t X = grid.xs.size();
  for (size_t r = 0; r < grid.ys.size(); ++r)
    for (int c = 0; c < channels; ++c) {
      const T* row = planes[c] + size_t(grid.ys[r]) * size_t(width);
      uint16_t* out = codes.data() + ((r * size_t(images) + size_t(i)) * channels + c) * X;
      for (size_t k = 0; k < X; ++k) out[k] = row[grid.xs[k]];
    }
}
template void StackProbe::Take<uint8_t>(int, const uint8_t* const*, int);
template void StackProbe::Take<uint16_t>(int, const uint16_t* const*, int);

}  // namespace matfit
