// Camera RAW (issue 20, item 3): a LinearRaw DNG written here is read through OpenImageIO's
// libraw plugin as linear values with the camera's white balance, alone and as a lights.txt set.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/image_io.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// ---- camera RAW (DNG) ------------------------------------------------------------------------

// A minimal uncompressed LinearRaw DNG (TIFF/EP, DNG 1.4): 16-bit RGB `codes` (w × h × 3,
// interleaved) from a camera whose native space is linear sRGB (ColorMatrix1 = XYZ→sRGB) and
// the as-shot white balance `neutral` (the camera's response to white, per channel).
void WriteLinearDng(const std::string& path, int w, int h, const std::vector<uint16_t>& codes,
                    const double neutral[3]) {
  struct Entry {
    uint16_t tag, type;
    uint32_t count;
    std::vector<uint8_t> value;
  };
  auto le = [](std::vector<uint8_t>* v, uint64_t x, int bytes) {
    for (int i = 0; i < bytes; ++i) v->push_back(uint8_t(x >> (8 * i)));
  };
  std::vector<Entry> e;
  auto add = [&](uint16_t tag, uint16_t type, std::vector<int64_t> vals, int bytes) {
    Entry en{tag, type, uint32_t(vals.size()), {}};
    for (int64_t v : vals) le(&en.value, uint64_t(v), bytes);
    if (type == 5 || type == 10) en.count /= 2;  // (numerator, denominator) pairs
    e.push_back(en);
  };
  auto ascii = [&](uint16_t tag, const std::string& s) {
    Entry en{tag, 2, uint32_t(s.size() + 1), std::vector<uint8_t>(s.begin(), s.end())};
    en.value.push_back(0);
    e.push_back(en);
  };
  const uint32_t pixel_bytes = uint32_t(codes.size() * 2);
  add(254, 4, {0}, 4);
  add(256, 4, {w}, 4);
  add(257, 4, {h}, 4);
  add(258, 3, {16, 16, 16}, 2);
  add(259, 3, {1}, 2);
  add(262, 3, {34892}, 2);  // LinearRaw
  ascii(271, "matfit");
  ascii(272, "test camera");
  add(273, 4, {0}, 4);  // strip offset, patched below
  add(274, 3, {1}, 2);
  add(277, 3, {3}, 2);
  add(278, 4, {h}, 4);
  add(279, 4, {pixel_bytes}, 4);
  add(284, 3, {1}, 2);
  add(50706, 1, {1, 4, 0, 0}, 1);  // DNGVersion
  ascii(50708, "matfit test camera");
  add(50714, 4, {0}, 4);      // BlackLevel
  add(50717, 4, {65535}, 4);  // WhiteLevel
  const double xyz_to_srgb[9] = {3.2404542, -1.5371385, -0.4985314, -0.9692660, 1.8760108,
                                 0.0415560, 0.0556434,  -0.2040259, 1.0572252};
  std::vector<int64_t> cm;
  for (double v : xyz_to_srgb)
    cm.push_back(uint32_t(int32_t(std::lround(v * 10000)))), cm.push_back(10000);
  add(50721, 10, cm, 4);  // ColorMatrix1
  std::vector<int64_t> as_shot;
  for (int c = 0; c < 3; ++c)
    as_shot.push_back(std::lround(neutral[c] * 10000)), as_shot.push_back(10000);
  add(50728, 5, as_shot, 4);  // AsShotNeutral
  add(50778, 3, {21}, 2);     // CalibrationIlluminant1 = D65
  std::sort(e.begin(), e.end(), [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
  const uint32_t ifd = 8, extra0 = ifd + 2 + 12 * uint32_t(e.size()) + 4;
  std::vector<uint8_t> extra, dir;
  std::vector<uint32_t> offsets(e.size(), 0);
  for (size_t i = 0; i < e.size(); ++i)
    if (e[i].value.size() > 4) {
      offsets[i] = extra0 + uint32_t(extra.size());
      extra.insert(extra.end(), e[i].value.begin(), e[i].value.end());
      if (extra.size() % 2) extra.push_back(0);
    }
  const uint32_t data = extra0 + uint32_t(extra.size());
  le(&dir, e.size(), 2);
  for (size_t i = 0; i < e.size(); ++i) {
    le(&dir, e[i].tag, 2);
    le(&dir, e[i].type, 2);
    le(&dir, e[i].count, 4);
    if (e[i].tag == 273) {
      le(&dir, data, 4);
    } else if (offsets[i]) {
      le(&dir, offsets[i], 4);
    } else {
      std::vector<uint8_t> v = e[i].value;
      v.resize(4, 0);
      dir.insert(dir.end(), v.begin(), v.end());
    }
  }
  le(&dir, 0, 4);
  std::ofstream out(path, std::ios::binary);
  const uint8_t header[8] = {'I', 'I', 42, 0, 8, 0, 0, 0};
  out.write(reinterpret_cast<const char*>(header), 8);
  out.write(reinterpret_cast<const char*>(dir.data()), std::streamsize(dir.size()));
  out.write(reinterpret_cast<const char*>(extra.data()), std::streamsize(extra.size()));
  out.write(reinterpret_cast<const char*>(codes.data()), std::streamsize(pixel_bytes));
}

TEST(CameraRaw, DngReadsLinearWithTheCamerasWhiteBalance) {
  TempDir tmp;
  const int w = 64, h = 32;  // libraw leaves images under 32 rows unbalanced
  std::vector<uint16_t> codes(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) codes[(size_t(y) * w + x) * 3 + c] = uint16_t(x * 800 + 1000);
  const double neutral_white[3] = {1, 1, 1};
  WriteLinearDng(tmp / "grey.dng", w, h, codes, neutral_white);
  ImageFileInfo info;
  auto img = ReadImage(tmp / "grey.dng", {}, &info);
  ASSERT_TRUE(img.ok()) << img.status().ToString();
  ASSERT_EQ(img->width(), w);
  ASSERT_EQ(img->channels(), 3);
  EXPECT_EQ(info.encoding.transfer, TransferFunction::kLinear) << info.encoding_reason;
  // Linear: value ∝ code (no gamma, no automatic brightening): v(x) / code(x) is one constant.
  const double k = img->At(1, 4, 20) / codes[(4 * w + 20) * 3 + 1];
  for (int x = 4; x < w; x += 7)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(img->At(c, 4, x) / codes[(4 * w + x) * 3 + c], k, 0.02 * k) << x << " " << c;
  // The camera's white balance: a camera that sees white as (0.5, 1, 1) has its red doubled.
  const double neutral_red[3] = {0.5, 1, 1};
  WriteLinearDng(tmp / "red.dng", w, h, codes, neutral_red);
  auto red = ReadImage(tmp / "red.dng");
  ASSERT_TRUE(red.ok()) << red.status().ToString();
  const double ratio = red->At(0, 4, 20) / red->At(1, 4, 20);
  EXPECT_NEAR(ratio, 2.0, 0.1);
}

TEST(CameraRaw, ALightsTxtSetOfDngFilesLoads) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  fs::create_directories(tmp / "raw");
  fs::copy_file(tmp / "obj/lights.txt", tmp / "raw/lights.txt");
  const double white[3] = {1, 1, 1};
  for (int i = 0; i < 12; ++i) {
    std::vector<uint16_t> codes(20 * 16 * 3);
    for (int p = 0; p < 20 * 16; ++p)
      for (int c = 0; c < 3; ++c)
        codes[p * 3 + c] = uint16_t(std::lround(truth.Sample(i, c, p) * 65535));
    WriteLinearDng(tmp / ("raw/IMG_" + std::to_string(100 + i) + ".dng"), 20, 16, codes, white);
  }
  auto s = ReadDataset(tmp / "raw");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->num_images(), 12);
  // Same images up to the camera pipeline's scale: the ratio to the truth is one constant.
  double num = 0, den = 0;
  for (int i = 0; i < 12; ++i)
    for (int64_t p = 0; p < 20 * 16; ++p) num += s->Sample(i, 1, p), den += truth.Sample(i, 1, p);
  const double k = num / den;
  double worst = 0;
  for (int i = 0; i < 12; ++i)
    for (int64_t p = 0; p < 20 * 16; ++p)
      worst = std::max(worst, std::abs(s->Sample(i, 1, p) - k * truth.Sample(i, 1, p)));
  EXPECT_LT(worst, 0.01 * k) << "scale " << k;
}

}  // namespace
}  // namespace matfit
