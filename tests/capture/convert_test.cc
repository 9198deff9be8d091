// Frame conversion edge cases: MJPEG decoded from memory, short buffers, odd YUYV widths.
#include "capture/convert.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/color.h"

namespace matfit::capture {
namespace {

TEST(Convert, MjpegFramesDecodeFromMemoryAsSrgb) {
  const int w = 16, h = 8;
  std::vector<uint8_t> rgb(size_t(w) * h * 3);
  for (int i = 0; i < w * h; ++i)
    for (int c = 0; c < 3; ++c) rgb[size_t(3 * i + c)] = uint8_t(40 + (i % w) * 8);  // grey ramp
  const std::string path = std::filesystem::temp_directory_path() /
                           ("matfit_mjpeg_" + std::to_string(::getpid()) + ".jpg");
  {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("CompressionQuality", 100);
    ASSERT_TRUE(out->open(path, spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, rgb.data()));
    out->close();
  }
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  const std::string jpeg = s.str();
  std::filesystem::remove(path);
  auto img = ConvertFrame(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size(),
                          {PixelFormat::kMjpeg, w, h});
  ASSERT_TRUE(img.ok()) << img.status().message();
  ASSERT_EQ(img->channels(), 3);
  // Lossy, but at quality 100 within a few codes of the source, linearised with sRGB.
  double worst = 0;
  for (int i = 0; i < w * h; ++i)
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, double(std::abs(img->Plane(c)[i] -
                                              SrgbToLinear(float(40 + (i % w) * 8) / 255.0f))));
  EXPECT_LT(worst, 0.01);
  auto bad = ConvertFrame(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size() / 3,
                          {PixelFormat::kMjpeg, w, h});
  auto wrong = ConvertFrame(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size(),
                            {PixelFormat::kMjpeg, 32, 8});
  EXPECT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().message().find("negotiated format is 32x8"), std::string::npos);
  (void)bad;  // a truncated JPEG may still decode partially; it must not crash
}

TEST(Convert, ShortBuffersAndOddYuyvWidthsAreErrors) {
  std::vector<uint8_t> b(10);
  auto r = ConvertFrame(b.data(), b.size(), {PixelFormat::kY16, 4, 4});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("too short"), std::string::npos);
  std::vector<uint8_t> y(2 * 3 * 2);
  EXPECT_NE(ConvertFrame(y.data(), y.size(), {PixelFormat::kYuyv, 3, 2})
                .status()
                .message()
                .find("even width"),
            std::string::npos);
  auto junk = ConvertFrame(b.data(), b.size(), {PixelFormat::kMjpeg, 4, 4});
  EXPECT_FALSE(junk.ok());
}

}  // namespace
}  // namespace matfit::capture
