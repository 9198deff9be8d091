// LightStack: N images of one sample under N lights, as linear float32 planes.
//
// Layout (plane-major SoA): data[((i * C + c) * H + y) * W + x] for image i, channel c,
// row y (0 = top), column x. Directions are unit vectors in the sample's tangent frame
// (METHODS.md §0: z = surface normal toward the camera, x = image right, y = image up),
// pointing away from the surface.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/check.h"
#include "core/color.h"
#include "core/large_page_allocator.h"
#include "core/vec3.h"

namespace matfit {

struct LightSample {
  Vec3 direction{0, 0, 1};            // unit, toward the light
  Vec3 intensity{1, 1, 1};            // relative RGB intensity (1 = nominal)
  double theta_deg = 0, phi_deg = 0;  // direction as parsed or derived (METHODS.md §0)
};

class LightStack {
 public:
  LightStack() = default;
  // Allocates zeroed planes; lights are default (frontal, unit intensity).
  LightStack(int width, int height, int channels, int num_images);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  int num_images() const { return num_images_; }
  int64_t plane_size() const { return int64_t(width_) * height_; }
  int64_t texels() const { return plane_size(); }

  std::span<float> Plane(int image, int channel) {
    return {data_.data() + PlaneOffset(image, channel), size_t(plane_size())};
  }
  std::span<const float> Plane(int image, int channel) const {
    return {data_.data() + PlaneOffset(image, channel), size_t(plane_size())};
  }
  float& At(int image, int channel, int y, int x) {
    MATFIT_DCHECK(y >= 0 && y < height_ && x >= 0 && x < width_);
    return data_[PlaneOffset(image, channel) + int64_t(y) * width_ + x];
  }
  float At(int image, int channel, int y, int x) const {
    MATFIT_DCHECK(y >= 0 && y < height_ && x >= 0 && x < width_);
    return data_[PlaneOffset(image, channel) + int64_t(y) * width_ + x];
  }
  // Row y, columns [x0, x0 + n) of (image, channel) as linear floats. Kernels read the stack
  // through this: it points into the planes for float stacks, and decodes into `scratch`
  // (n floats, caller-owned) for stacks held at their native depth.
  const float* Row(int image, int channel, int y, int x0, int n, float* scratch) const {
    (void)scratch, (void)n;  // n is read by MATFIT_DCHECK only (compiled out in release)
    MATFIT_DCHECK(y >= 0 && y < height_ && x0 >= 0 && x0 + n <= width_);
    return data_.data() + PlaneOffset(image, channel) + int64_t(y) * width_ + x0;
  }
  // The same for a run of n texels starting at row-major texel index p (may span rows).
  const float* Texels(int image, int channel, int64_t p, int n, float* scratch) const {
    (void)scratch, (void)n;  // n is read by MATFIT_DCHECK only (compiled out in release)
    MATFIT_DCHECK(p >= 0 && p + n <= plane_size());
    return data_.data() + PlaneOffset(image, channel) + p;
  }
  const float* data() const { return data_.data(); }
  float* data() { return data_.data(); }

  std::vector<LightSample>& lights() { return lights_; }
  const std::vector<LightSample>& lights() const { return lights_; }

  // View direction (unit, tangent frame); frontal (0,0,1) for rectified BTF views.
  Vec3 view_direction{0, 0, 1};
  double view_theta_deg = 0, view_phi_deg = 0;
  // Optional validity mask (1 = sample texel), plane_size() bytes; empty = every texel valid.
  std::vector<uint8_t> mask;
  // Physical size of one texel in millimetres; 0 = unknown.
  double mm_per_texel = 0;

  // Provenance, filled by readers: layout name, source folder, one file per image.
  std::string layout, source, object_name;
  std::vector<std::string> image_files;
  // How the files were linearised (one entry per image) and what decoding noticed.
  std::vector<ColorEncoding> encodings;
  std::vector<std::string> encoding_reasons;
  std::vector<int64_t> saturated_pixels;   // per image, integer formats only
  std::vector<int64_t> nonfinite_samples;  // per image, float formats only

  bool has_mask() const { return !mask.empty(); }
  int64_t MaskedTexels() const;  // texels inside the mask (all when no mask)
  // Bytes held by the pixel planes and the mask.
  size_t MemoryBytes() const;

 private:
  int64_t PlaneOffset(int image, int channel) const {
    MATFIT_DCHECK(image >= 0 && image < num_images_ && channel >= 0 && channel < channels_);
    return (int64_t(image) * channels_ + channel) * plane_size();
  }

  int width_ = 0, height_ = 0, channels_ = 0, num_images_ = 0;
  std::vector<float, LargePageAllocator<float>> data_;
  std::vector<LightSample> lights_;
};

// A stack holding only images `indices` of `stack` (in that order), with their lights and
// provenance; mask, view and physical size are kept.
LightStack SelectImages(const LightStack& stack, const std::vector<int>& indices);

}  // namespace matfit
