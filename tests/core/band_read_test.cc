// Reading a band of rows (a rank of a distributed fit, docs/scale-out.md): every codec's
// ReadRows gives exactly those rows of the whole decode — JPEG (skipped scanlines), PNG (plain and
// Adam7-interlaced), EXR, and OpenImageIO's formats (TIFF) — and a dataset read with
// ReadOptions::rows is those rows of the whole stack, mask and per-image counts included.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/image_codec.h"
#include "core/image_io.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

using testing::WavePattern;

size_t PixelBytes(const codec::Header& h) {
  const size_t s = h.sample == codec::Sample::kUint8    ? 1
                   : h.sample == codec::Sample::kUint16 ? 2
                                                        : 4;
  return s * size_t(h.channels) * size_t(h.width);
}

// Every band of `path` read on its own equals those rows of the whole decode.
void ExpectBandsAreRowsOfTheWhole(const std::string& path) {
  SCOPED_TRACE(path);
  std::string error;
  auto whole_reader = codec::OpenAny(path, &error);
  ASSERT_TRUE(whole_reader) << error;
  const codec::Header h = whole_reader->header();
  const size_t row = PixelBytes(h);
  std::vector<unsigned char> whole(row * size_t(h.height));
  ASSERT_TRUE(whole_reader->Read(whole.data())) << whole_reader->error();
  const int H = h.height;
  for (auto [y0, y1] : std::vector<std::pair<int, int>>{
           {0, 1}, {0, 7}, {5, 23}, {16, 32}, {23, H}, {H - 1, H}, {0, H}}) {
    auto r = codec::OpenAny(path, &error);
    ASSERT_TRUE(r) << error;
    std::vector<unsigned char> band(row * size_t(y1 - y0));
    ASSERT_TRUE(r->ReadRows(y0, y1, band.data())) << r->error();
    EXPECT_TRUE(std::equal(band.begin(), band.end(), whole.begin() + ptrdiff_t(row * y0)))
        << "rows " << y0 << ".." << y1 << " differ from the whole decode";
  }
}

// An Adam7-interlaced RGB PNG (matfit never writes one; cameras and editors do).
void WriteInterlacedPng(const std::string& path, const Image& img) {
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_TRUE(f);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, f);
  png_set_IHDR(png, info, img.width(), img.height(), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<png_byte> pixels(size_t(img.width()) * img.height() * 3);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c)
        pixels[(size_t(y) * img.width() + x) * 3 + c] =
            png_byte(std::lround(255 * img.At(c, y, x)));
  std::vector<png_bytep> rows(size_t(img.height()));
  for (int y = 0; y < img.height(); ++y) rows[size_t(y)] = &pixels[size_t(y) * img.width() * 3];
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

TEST(BandRead, EveryCodecReadsExactlyTheBandsRows) {
  TempDir dir;
  const fs::path tmp = dir.path();
  const Image img = WavePattern(67, 41, 3);
  ASSERT_TRUE(WriteImage(tmp / "a.jpg", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ASSERT_TRUE(WriteImage(tmp / "a8.png", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ASSERT_TRUE(
      WriteImage(tmp / "a16.png", img, {PixelFormat::kUint16, TransferFunction::kLinear}).ok());
  ASSERT_TRUE(
      WriteImage(tmp / "a.exr", img, {PixelFormat::kFloat, TransferFunction::kLinear}).ok());
  ASSERT_TRUE(WriteImage(tmp / "ah.exr", img,
                         {PixelFormat::kHalf, TransferFunction::kLinear,
                          /*compact=*/true})
                  .ok());
  ASSERT_TRUE(
      WriteImage(tmp / "a.tif", img, {PixelFormat::kUint16, TransferFunction::kLinear}).ok());
  WriteInterlacedPng(tmp / "adam7.png", img);
  for (const char* f : {"a.jpg", "a8.png", "a16.png", "a.exr", "ah.exr", "a.tif", "adam7.png"})
    ExpectBandsAreRowsOfTheWhole(tmp / f);
  // A tiled TIFF (scanline reads are refused on tiles): OpenImageIO's tools make one.
  const std::string tiled = tmp / "tiled.tif";
  if (std::system(("oiiotool '" + (tmp / "a.tif").string() + "' --tile 16 16 -o '" + tiled +
                   "' > /dev/null 2>&1")
                      .c_str()) == 0)
    ExpectBandsAreRowsOfTheWhole(tiled);
  else
    std::printf("note: oiiotool absent (openimageio-tools): tiled TIFF bands not checked\n");
}

TEST(BandRead, ImageRowsOutsideTheImageAreAnError) {
  TempDir dir;
  const fs::path tmp = dir.path();
  ASSERT_TRUE(WriteImage(tmp / "a.png", WavePattern(8, 6, 1),
                         {PixelFormat::kUint8, TransferFunction::kSrgb})
                  .ok());
  ImageReadOptions o;
  o.row0 = 4, o.rows = 3;
  auto r = ReadImage(tmp / "a.png", o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("has 6 rows"), std::string::npos) << r.status().ToString();
}

// A .lp dataset of six 16-bit images, one pixel clipped in the last row, and a mask.
fs::path WriteLpSet(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream lp(dir / "set.lp");
  lp << "6\n";
  for (int i = 0; i < 6; ++i) {
    Image img = WavePattern(20, 13, 3);
    for (float& v : img.data()) v *= 0.5f + 0.1f * i;
    if (i == 2) img.At(1, 12, 4) = 1.0f;  // saturated: counted for the band holding row 12
    const std::string name = "img" + std::to_string(i) + ".png";
    EXPECT_TRUE(
        WriteImage(dir / name, img, {PixelFormat::kUint16, TransferFunction::kLinear}).ok());
    const double a = 2 * M_PI * i / 6;
    lp << name << " " << 0.6 * std::cos(a) << " " << 0.6 * std::sin(a) << " 0.8\n";
  }
  Image mask(20, 13, 1, 1.0f);
  for (int x = 0; x < 20; ++x) mask.At(0, 3, x) = 0;
  EXPECT_TRUE(
      WriteImage(dir / "mask.png", mask, {PixelFormat::kUint8, TransferFunction::kLinear}).ok());
  return dir / "set.lp";
}

TEST(BandRead, DatasetBandIsThoseRowsOfTheWholeStack) {
  TempDir dir;
  const fs::path lp = WriteLpSet(dir.path());
  auto whole = ReadDataset(lp.string());
  ASSERT_TRUE(whole.ok()) << whole.status().ToString();
  int64_t saturated = 0;
  for (int y0 = 0; y0 < 13; y0 += 5) {
    ReadOptions o;
    o.row0 = y0, o.rows = std::min(5, 13 - y0);
    auto band = ReadDataset(lp.string(), o);
    ASSERT_TRUE(band.ok()) << band.status().ToString();
    EXPECT_EQ(band->height(), o.rows);
    EXPECT_EQ(band->full_height(), 13);
    EXPECT_EQ(band->band.row0, y0);
    EXPECT_FALSE(band->is_band());  // no communicator until a fit joins the bands
    for (int i = 0; i < 6; ++i)
      for (int c = 0; c < 3; ++c)
        for (int y = 0; y < o.rows; ++y)
          for (int x = 0; x < 20; ++x) ASSERT_EQ(band->At(i, c, y, x), whole->At(i, c, y0 + y, x));
    ASSERT_EQ(band->mask.size(), size_t(20 * o.rows));
    for (int y = 0; y < o.rows; ++y)
      EXPECT_EQ(band->mask[size_t(y) * 20], whole->mask[size_t(y0 + y) * 20]) << "row " << y0 + y;
    saturated += band->saturated_pixels[2];
  }
  EXPECT_EQ(saturated, whole->saturated_pixels[2]);
  EXPECT_EQ(saturated, 1);
  ReadOptions beyond;
  beyond.row0 = 10, beyond.rows = 5;
  auto bad = ReadDataset(lp.string(), beyond);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("images have 13 rows"), std::string::npos)
      << bad.status().ToString();
}

}  // namespace
}  // namespace matfit
