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

LightStack SelectImages(const LightStack& s, const std::vector<int>& idx) {
  LightStack out(s.width(), s.height(), s.channels(), int(idx.size()));
  auto pick = [&](const auto& v, auto& dst) {
    if (v.size() == size_t(s.num_images()))
      for (int i : idx) dst.push_back(v[i]);
  };
  for (size_t k = 0; k < idx.size(); ++k) {
    const int i = idx[k];
    MATFIT_CHECK(i >= 0 && i < s.num_images());
    out.lights()[k] = s.lights()[i];
    for (int c = 0; c < s.channels(); ++c) {
      auto src = s.Plane(i, c);
      std::copy(src.begin(), src.end(), out.Plane(int(k), c).begin());
    }
  }
  out.view_direction = s.view_direction;
  out.view_theta_deg = s.view_theta_deg, out.view_phi_deg = s.view_phi_deg;
  out.mask = s.mask;
  out.mm_per_texel = s.mm_per_texel;
  out.layout = s.layout, out.source = s.source, out.object_name = s.object_name;
  pick(s.image_files, out.image_files);
  pick(s.encodings, out.encodings);
  pick(s.encoding_reasons, out.encoding_reasons);
  pick(s.saturated_pixels, out.saturated_pixels);
  pick(s.nonfinite_samples, out.nonfinite_samples);
  return out;
}

}  // namespace matfit
