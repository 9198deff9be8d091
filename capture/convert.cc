#include "capture/convert.h"

#include <algorithm>
#include <vector>

#include "core/color.h"
#include "core/image_codec.h"

namespace matfit::capture {
namespace {

constexpr const char* kNames[] = {"YUYV", "MJPEG", "GREY", "Y16", "RGB24"};

float Clamp01(float v) { return std::min(1.0f, std::max(0.0f, v)); }

}  // namespace

const char* PixelFormatName(PixelFormat f) { return kNames[int(f)]; }

bool ParsePixelFormat(const std::string& name, PixelFormat* out) {
  for (int i = 0; i < 5; ++i)
    if (name == kNames[i]) return *out = PixelFormat(i), true;
  return false;
}

int BytesPerPixel(PixelFormat f) {
  switch (f) {
    case PixelFormat::kYuyv: return 2;
    case PixelFormat::kGrey: return 1;
    case PixelFormat::kY16: return 2;
    case PixelFormat::kRgb24: return 3;
    case PixelFormat::kMjpeg: return 0;
  }
  return 0;
}

StatusOr<Image> ConvertFrame(const uint8_t* bytes, size_t size, const FrameFormat& f,
                             size_t bytesperline) {
  const int w = f.width, h = f.height;
  if (w <= 0 || h <= 0) return InvalidArgument("frame size must be positive");
  const float* srgb = Srgb8ToLinearTable();
  if (f.pixel_format == PixelFormat::kMjpeg) {
    // Decode from memory (core's JPEG codec); the JPEG carries sRGB values.
    std::string error;
    auto in = codec::OpenJpegMemory(bytes, size, &error);
    if (!in)
      return DataError("MJPEG frame is not a valid JPEG (" + std::to_string(size) +
                       " bytes): " + error);
    const codec::Header& spec = in->header();
    if (spec.width != w || spec.height != h)
      return DataError("MJPEG frame is " + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + ", the negotiated format is " +
                       std::to_string(w) + "x" + std::to_string(h));
    const int ch = spec.channels;
    std::vector<uint8_t> px(size_t(w) * h * ch);
    if (!in->Read(px.data())) return DataError("MJPEG frame could not be decoded: " + in->error());
    const int out_ch = ch >= 3 ? 3 : 1;
    Image img(w, h, out_ch);
    for (int c = 0; c < out_ch; ++c)
      for (int64_t i = 0; i < int64_t(w) * h; ++i) img.Plane(c)[i] = srgb[px[size_t(i) * ch + c]];
    return img;
  }
  const int bpp = BytesPerPixel(f.pixel_format);
  const size_t stride = bytesperline ? bytesperline : size_t(w) * bpp;
  if (stride < size_t(w) * bpp || size < stride * size_t(h - 1) + size_t(w) * bpp)
    return DataError(std::string(PixelFormatName(f.pixel_format)) + " frame of " +
                     std::to_string(size) + " bytes is too short for " + std::to_string(w) + "x" +
                     std::to_string(h));
  if (f.pixel_format == PixelFormat::kYuyv && (w % 2) != 0)
    return DataError("YUYV frames need an even width, got " + std::to_string(w));
  const bool colour = f.pixel_format == PixelFormat::kYuyv || f.pixel_format == PixelFormat::kRgb24;
  Image img(w, h, colour ? 3 : 1);
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = bytes + stride * size_t(y);
    const int64_t o = int64_t(y) * w;
    switch (f.pixel_format) {
      case PixelFormat::kGrey:
        for (int x = 0; x < w; ++x) img.Plane(0)[o + x] = srgb[row[x]];
        break;
      case PixelFormat::kY16:  // little-endian, linear
        for (int x = 0; x < w; ++x)
          img.Plane(0)[o + x] = float(uint16_t(row[2 * x] | (row[2 * x + 1] << 8))) / 65535.0f;
        break;
      case PixelFormat::kRgb24:
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c) img.Plane(c)[o + x] = srgb[row[3 * x + c]];
        break;
      case PixelFormat::kYuyv:
        // Y0 U Y1 V per pixel pair; BT.601 limited range: Y in [16, 235], U, V in [16, 240].
        for (int x = 0; x < w; x += 2) {
          const uint8_t* p = row + 2 * x;
          const float u = (float(p[1]) - 128.0f) / 224.0f, v = (float(p[3]) - 128.0f) / 224.0f;
          for (int k = 0; k < 2; ++k) {
            const float yy = (float(p[2 * k]) - 16.0f) / 219.0f;
            const float r = yy + 1.402f * v, g = yy - 0.344136f * u - 0.714136f * v,
                        b = yy + 1.772f * u;
            img.Plane(0)[o + x + k] = SrgbToLinear(Clamp01(r));
            img.Plane(1)[o + x + k] = SrgbToLinear(Clamp01(g));
            img.Plane(2)[o + x + k] = SrgbToLinear(Clamp01(b));
          }
        }
        break;
      case PixelFormat::kMjpeg: break;
    }
  }
  return img;
}

}  // namespace matfit::capture
