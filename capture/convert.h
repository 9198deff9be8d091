// Camera pixel formats → linear float planes. 8-bit formats are taken as sRGB-encoded (what
// UVC cameras deliver) and linearised; Y16 is linear. YUYV uses BT.601 limited range.
#pragma once

#include <cstddef>
#include <cstdint>

#include "capture/camera.h"

namespace matfit::capture {

// `bytes` holds one frame of `f`; `bytesperline` is the row stride (0 = packed). MJPEG frames
// are decoded with libjpeg (core/image_codec.h). Errors name the format and what was wrong
// (short buffer, bad JPEG).
StatusOr<Image> ConvertFrame(const uint8_t* bytes, size_t size, const FrameFormat& f,
                             size_t bytesperline = 0);

// Bytes per pixel of the packed formats (MJPEG: 0).
int BytesPerPixel(PixelFormat f);

}  // namespace matfit::capture
