#include "core/light_stack.h"

#include <algorithm>

namespace matfit {

LightStack::LightStack(int width, int height, int channels, int num_images)
    : width_(width), height_(height), channels_(channels), num_images_(num_images) {
  MATFIT_CHECK(width >= 0 && height >= 0 && num_images >= 0);
  MATFIT_CHECK(channels == 1 || channels == 3, "stacks hold 1 or 3 channels");
  data_.assign(size_t(plane_size()) * channels * num_images, 0.0f);
  lights_.resize(num_images);
}

int64_t LightStack::MaskedTexels() const {
  if (mask.empty()) return plane_size();
  return std::count_if(mask.begin(), mask.end(), [](uint8_t m) { return m != 0; });
}

size_t LightStack::MemoryBytes() const { return data_.size() * sizeof(float) + mask.size(); }

}  // namespace matfit
