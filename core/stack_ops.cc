#include "core/stack_ops.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace matfit {
namespace {

// The fits' clip test (fit/fit_common.h kClipLevel): samples at the file's maximum code.
constexpr float kClippedLevel = 0.9999f;

// Same metadata, w × h; native sample type and table when `native`, else float32.
LightStack EmptyLike(const LightStack& s, int w, int h, bool native) {
  LightStack out = native ? LightStack(w, h, s.channels(), s.num_images(), s.sample_type(), s.lut())
                          : LightStack(w, h, s.channels(), s.num_images());
  CopyStackMetadata(s, &out);
  return out;
}

}  // namespace

void CopyStackMetadata(const LightStack& s, LightStack* out) {
  out->lights() = s.lights();
  out->view_direction = s.view_direction;
  out->view_theta_deg = s.view_theta_deg, out->view_phi_deg = s.view_phi_deg;
  out->mm_per_texel = s.mm_per_texel;
  out->near_frame = s.near_frame;
  out->layout = s.layout, out->source = s.source, out->object_name = s.object_name;
  out->image_files = s.image_files;
  out->encodings = s.encodings, out->encoding_reasons = s.encoding_reasons;
  out->saturated_pixels = s.saturated_pixels, out->nonfinite_samples = s.nonfinite_samples;
  out->band = s.band;
  out->mask_source = s.mask_source;
  out->source_width = s.source_width, out->source_height = s.source_height;
  out->crop_x = s.crop_x, out->crop_y = s.crop_y, out->crop_w = s.crop_w, out->crop_h = s.crop_h;
}

StatusOr<LightStack> CropStack(const LightStack& s, int x, int y, int w, int h) {
  if (w < 1 || h < 1 || x < 0 || y < 0 || x + w > s.width() || y + h > s.height())
    return InvalidArgument("crop " + std::to_string(w) + "x" + std::to_string(h) + "+" +
                           std::to_string(x) + "+" + std::to_string(y) + " is outside the " +
                           std::to_string(s.width()) + "x" + std::to_string(s.height()) + " stack");
  LightStack out = EmptyLike(s, w, h, /*native=*/true);
  out.near_frame.x0 += x * s.near_frame.step, out.near_frame.y0 -= y * s.near_frame.step;
  auto crop = [&](auto src, auto dst) {  // one plane, samples copied as stored
    for (int r = 0; r < h; ++r)
      std::copy_n(src.data() + int64_t(y + r) * s.width() + x, w, dst.data() + int64_t(r) * w);
  };
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < s.channels(); ++c) switch (s.sample_type()) {
        case SampleType::kFloat32: crop(s.Plane(i, c), out.Plane(i, c)); break;
        case SampleType::kUint8: crop(s.Codes<uint8_t>(i, c), out.Codes<uint8_t>(i, c)); break;
        case SampleType::kUint16: crop(s.Codes<uint16_t>(i, c), out.Codes<uint16_t>(i, c)); break;
      }
  if (s.has_mask()) {
    out.mask.resize(size_t(w) * h);
    for (int r = 0; r < h; ++r)
      std::copy_n(s.mask.data() + int64_t(y + r) * s.width() + x, w,
                  out.mask.data() + int64_t(r) * w);
  }
  return out;
}

StatusOr<LightStack> DownsampleStack(const LightStack& s, int f) {
  if (f < 1) return InvalidArgument("downsample factor must be ≥ 1, got " + std::to_string(f));
  const int w = s.width() / f, h = s.height() / f;
  if (w < 1 || h < 1)
    return InvalidArgument("downsampling the " + std::to_string(s.width()) + "x" +
                           std::to_string(s.height()) + " stack by " + std::to_string(f) +
                           " leaves no texel");
  if (f == 1) return CropStack(s, 0, 0, s.width(), s.height());
  LightStack out = EmptyLike(s, w, h, /*native=*/false);  // block means are not codes
  out.mm_per_texel = s.mm_per_texel * f;
  // Block (bx, by) is centred on source texel (bx·f + (f − 1)/2, by·f + (f − 1)/2).
  const double half = 0.5 * (f - 1) * s.near_frame.step;
  out.near_frame = {s.near_frame.x0 + half, s.near_frame.y0 - half, s.near_frame.step * f};
  // A band of a distributed stack whose first row is a multiple of f (fit/bands.h): the same
  // band of the downsampled stack (the rows of an incomplete last block are dropped, as here).
  if (s.band.row0 % f != 0)
    return InvalidArgument("downsampling a band of rows that starts at row " +
                           std::to_string(s.band.row0) + " by " + std::to_string(f) +
                           ": a distributed stack's bands must start on a block");
  out.band.row0 = s.band.row0 / f, out.band.full_height = s.full_height() / f;
  bool may_clip = false;
  for (int64_t v : s.saturated_pixels) may_clip = may_clip || v > 0;
  // Per block: which source texels count (mask) and the block's own mask bit.
  std::vector<uint8_t> inside(size_t(w) * h, 1);
  auto in_mask = [&](int64_t p) { return !s.has_mask() || s.mask[p] != 0; };
  if (s.has_mask()) {
    out.mask.assign(size_t(w) * h, 0);
    for (int by = 0; by < h; ++by)
      for (int bx = 0; bx < w; ++bx) {
        int k = 0;
        for (int dy = 0; dy < f; ++dy)
          for (int dx = 0; dx < f; ++dx)
            k += in_mask(int64_t(by * f + dy) * s.width() + bx * f + dx);
        out.mask[size_t(by) * w + bx] = inside[size_t(by) * w + bx] = 2 * k >= f * f;
      }
  }
  std::vector<float> scratch(s.is_float() ? 0 : size_t(s.plane_size()));
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < s.channels(); ++c) {
      const float* src = s.Texels(i, c, 0, int(s.plane_size()), scratch.data());
      float* dst = out.Plane(i, c).data();
      for (int by = 0; by < h; ++by)
        for (int bx = 0; bx < w; ++bx) {
          double sum = 0;
          int k = 0;
          bool clipped = false;
          for (int dy = 0; dy < f; ++dy)
            for (int dx = 0; dx < f; ++dx) {
              const int64_t p = int64_t(by * f + dy) * s.width() + bx * f + dx;
              if (inside[size_t(by) * w + bx] && !in_mask(p)) continue;
              if (!std::isfinite(src[p])) continue;  // a lost sample does not poison the block
              clipped = clipped || (may_clip && src[p] >= kClippedLevel);
              sum += src[p], ++k;
            }
          // A block with a clipped sample stays at the clip code, so fits still see it clipped.
          dst[int64_t(by) * w + bx] = k == 0 ? NAN : clipped ? 1.0f : float(sum / k);
        }
    }
  return out;
}

LightStack QuantiseStack(const LightStack& s, int bits) {
  MATFIT_CHECK(bits == 8 || bits == 16, "QuantiseStack: 8 or 16 bits");
  const ColorEncoding enc{bits == 8 ? TransferFunction::kSrgb : TransferFunction::kLinear, 1.0f};
  const SampleType type = bits == 8 ? SampleType::kUint8 : SampleType::kUint16;
  LightStack out(s.width(), s.height(), s.channels(), s.num_images(), type,
                 LinearDecodeTable(enc, bits));
  out.lights() = s.lights();
  out.view_direction = s.view_direction;
  out.view_theta_deg = s.view_theta_deg, out.view_phi_deg = s.view_phi_deg;
  out.mm_per_texel = s.mm_per_texel;
  out.near_frame = s.near_frame;
  out.layout = s.layout, out.source = s.source, out.object_name = s.object_name;
  out.image_files = s.image_files;
  out.mask = s.mask;
  out.encodings.assign(s.num_images(), enc);
  out.encoding_reasons.assign(s.num_images(), "quantised in memory");
  out.saturated_pixels.assign(s.num_images(), 0);
  out.nonfinite_samples.assign(s.num_images(), 0);
  const int max = (1 << bits) - 1;
  std::vector<char> clipped(size_t(s.plane_size()));
  for (int i = 0; i < s.num_images(); ++i) {
    std::fill(clipped.begin(), clipped.end(), 0);
    for (int c = 0; c < s.channels(); ++c)
      for (int64_t p = 0; p < s.plane_size(); ++p) {
        const float v = s.Sample(i, c, p);
        const float e = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
        const int code = bits == 8 ? int(LinearToSrgb8(e)) : int(std::lround(e * 65535.0f));
        clipped[p] |= code == max;
        if (bits == 8)
          out.Codes<uint8_t>(i, c)[p] = uint8_t(code);
        else
          out.Codes<uint16_t>(i, c)[p] = uint16_t(code);
      }
    for (char k : clipped) out.saturated_pixels[i] += k;
  }
  return out;
}

void MaskBounds(const LightStack& s, int margin, int* x, int* y, int* w, int* h) {
  int x0 = s.width(), y0 = s.height(), x1 = -1, y1 = -1;
  if (!s.has_mask()) {
    *x = 0, *y = 0, *w = s.width(), *h = s.height();
    return;
  }
  for (int r = 0; r < s.height(); ++r)
    for (int c = 0; c < s.width(); ++c)
      if (s.mask[size_t(r) * s.width() + c])
        x0 = std::min(x0, c), x1 = std::max(x1, c), y0 = std::min(y0, r), y1 = std::max(y1, r);
  if (x1 < 0) {
    *x = 0, *y = 0, *w = s.width(), *h = s.height();
    return;
  }
  x0 = std::max(0, x0 - margin), y0 = std::max(0, y0 - margin);
  x1 = std::min(s.width() - 1, x1 + margin), y1 = std::min(s.height() - 1, y1 + margin);
  *x = x0, *y = y0, *w = x1 - x0 + 1, *h = y1 - y0 + 1;
}

}  // namespace matfit
