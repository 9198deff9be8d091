#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/image_io.h"
#include "core/large_page_allocator.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

Image Ramp(int w, int h, int ch) {
  Image img(w, h, ch);
  for (int c = 0; c < ch; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img.At(c, y, x) = float((x + 3 * y + 7 * c) % 64) / 63.0f;
  return img;
}

double MaxDiff(const Image& a, const Image& b) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.channels(), b.channels());
  double m = 0;
  for (size_t i = 0; i < a.data().size(); ++i)
    m = std::max(m, double(std::abs(a.data()[i] - b.data()[i])));
  return m;
}

// Half an 8-bit sRGB code in linear units near white: 0.5/255 · dL/dE(1) ≈ 0.0047.
constexpr double kHalfSrgbCode = 0.0048;

struct FormatCase {
  const char* ext;
  PixelFormat format;
  TransferFunction transfer;
  double tolerance;  // on linear values
};

const char* FormatName(PixelFormat f) {
  switch (f) {
    case PixelFormat::kUint8: return "8";
    case PixelFormat::kUint16: return "16";
    case PixelFormat::kHalf: return "half";
    case PixelFormat::kFloat: return "float";
  }
  return "";
}

class ImageRoundTrip : public ::testing::TestWithParam<FormatCase> {};

TEST_P(ImageRoundTrip, WriteThenReadGivesTheSameLinearValues) {
  const FormatCase& f = GetParam();
  TempDir tmp;
  const Image img = Ramp(17, 9, 3);
  const std::string path = tmp / (std::string("img") + f.ext);
  const Status written = WriteImage(path, img, {f.format, f.transfer});
  ASSERT_TRUE(written.ok()) << written.ToString();
  ImageFileInfo info;
  auto back = ReadImage(path, {}, &info);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_LE(MaxDiff(img, *back), f.tolerance) << f.ext << " " << info.encoding.ToString();
  EXPECT_EQ(info.encoding.transfer, f.transfer) << info.encoding_reason;
}

INSTANTIATE_TEST_SUITE_P(
    Formats, ImageRoundTrip,
    ::testing::Values(
        FormatCase{".png", PixelFormat::kUint16, TransferFunction::kLinear, 0.5 / 65535 + 1e-7},
        FormatCase{".png", PixelFormat::kUint8, TransferFunction::kSrgb, kHalfSrgbCode},
        FormatCase{".exr", PixelFormat::kFloat, TransferFunction::kLinear, 0.0},
        FormatCase{".exr", PixelFormat::kHalf, TransferFunction::kLinear, 1e-3},
        FormatCase{".tif", PixelFormat::kUint16, TransferFunction::kLinear, 0.5 / 65535 + 1e-7},
        FormatCase{".tga", PixelFormat::kUint8, TransferFunction::kSrgb, kHalfSrgbCode}),
    [](const auto& param_info) {
      return std::string(param_info.param.ext + 1) + FormatName(param_info.param.format);
    });

// 8-bit sRGB through OIIO must equal our exact table decode of the quantised codes.
TEST(ImageIo, EightBitSrgbQuantisationIsExact) {
  TempDir tmp;
  Image img = Ramp(16, 4, 3);
  ASSERT_TRUE(WriteImage(tmp / "a.png", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  auto back = ReadImage(tmp / "a.png");
  ASSERT_TRUE(back.ok());
  const float* lut = Srgb8ToLinearTable();
  for (size_t i = 0; i < img.data().size(); ++i)
    EXPECT_EQ(back->data()[i], lut[LinearToSrgb8(img.data()[i])]);
}

// 8-bit sRGB files hold round(255 · LinearToSrgb(clamp(v))) (LinearToSrgb8, with its pow) for
// every value: the two floats either side of every code boundary (found by bisection over the
// bit patterns of [0, 1], which order as the floats), out-of-range, infinite and NaN values;
// the alpha plane of RGBA stays linear.
TEST(ImageIo, EightBitSrgbCodesAreExactAtEveryBoundary) {
  std::vector<float> values = {0.0f,
                               -0.0f,
                               -1.0f,
                               1.0f,
                               1.5f,
                               7e-5f,
                               0.5f,
                               std::numeric_limits<float>::infinity(),
                               -std::numeric_limits<float>::infinity(),
                               std::numeric_limits<float>::quiet_NaN()};
  auto bits = [](float f) {
    uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
  };
  auto from_bits = [](uint32_t b) {
    float f;
    std::memcpy(&f, &b, sizeof f);
    return f;
  };
  for (int k = 1; k < 256; ++k) {  // the smallest float with code ≥ k, and the one below it
    uint32_t lo = 0, hi = bits(1.0f);
    while (lo < hi) {
      const uint32_t mid = lo + (hi - lo) / 2;
      if (LinearToSrgb8(from_bits(mid)) >= k)
        hi = mid;
      else
        lo = mid + 1;
    }
    ASSERT_EQ(LinearToSrgb8(from_bits(lo)), k);
    ASSERT_EQ(LinearToSrgb8(from_bits(lo - 1)), k - 1);
    values.push_back(from_bits(lo));
    values.push_back(from_bits(lo - 1));
  }
  const int w = int(values.size());
  TempDir tmp;
  for (int ch : {3, 4}) {
    Image img(w, 1, ch);
    for (int c = 0; c < ch; ++c)
      for (int x = 0; x < w; ++x) img.At(c, 0, x) = values[size_t((x + 7 * c) % w)];
    const std::string path = tmp / ("b" + std::to_string(ch) + ".png");
    ASSERT_TRUE(WriteImage(path, img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
    ImageReadOptions o;
    o.all_channels = true;
    auto back = ReadImageNative(path, o);
    ASSERT_TRUE(back.ok());
    ASSERT_EQ(back->channels, ch);
    for (int c = 0; c < ch; ++c)
      for (int x = 0; x < w; ++x) {
        const float v = img.At(c, 0, x);
        const uint8_t want =
            c == 3 ? uint8_t(std::isnan(v) ? 0 : std::lround(std::clamp(v, 0.0f, 1.0f) * 255))
                   : LinearToSrgb8(v);
        ASSERT_EQ(back->u8[size_t(c) * w + x], want) << "value " << v << ", channel " << c;
      }
  }
}

// ImageWriteOptions::compact changes only the encoder's effort: both settings read back
// bit for bit, and the compact files are smaller (a smooth image, which PIZ and zlib level 6
// compress better than uncompressed EXR and level 1).
TEST(ImageIo, CompactEncodingIsLosslessAndSmaller) {
  TempDir tmp;
  Image img(96, 64, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 96; ++x)
        img.Plane(c)[size_t(y) * 96 + x] =
            0.3f + 0.2f * std::sin(0.05f * x + c) * std::cos(0.07f * y);
  for (const auto& [file, format] :
       {std::pair{"m.exr", PixelFormat::kFloat}, std::pair{"m.png", PixelFormat::kUint16}}) {
    const std::string fast = tmp / (std::string("fast_") + file),
                      compact = tmp / (std::string("compact_") + file);
    ASSERT_TRUE(WriteImage(fast, img, {format, TransferFunction::kLinear, false}).ok());
    ASSERT_TRUE(WriteImage(compact, img, {format, TransferFunction::kLinear, true}).ok());
    auto a = ReadImage(fast), b = ReadImage(compact);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->data(), b->data()) << file;
    if (format == PixelFormat::kFloat) {
      EXPECT_EQ(a->data(), img.data()) << file;
    }
    EXPECT_LT(fs::file_size(compact), fs::file_size(fast)) << file;
  }
}

TEST(ImageIo, JpegRoundTripIsCloseAndSrgb) {
  TempDir tmp;
  Image img(32, 32, 3, 0.2f);
  ASSERT_TRUE(WriteImage(tmp / "a.jpg", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ImageFileInfo info;
  auto back = ReadImage(tmp / "a.jpg", {}, &info);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(info.encoding.transfer, TransferFunction::kSrgb);
  EXPECT_LT(MaxDiff(img, *back), 0.01);
}

// Decoding a file of its own sample type goes straight into the caller's buffer. OpenImageIO 2.4,
// asked for an explicit type (even the file's), stages the rows in a fresh 64 MiB buffer per
// image, and every page of it the image touches is a new page fault: 192 for a 512² RGB 8-bit
// image, 31 k of the 44 k faults of a 240-image decode. Counted, not timed: the process's minor
// faults over repeated reads after a warm-up.
// AddressSanitizer replaces malloc (no mallopt tuning, freed blocks quarantined): page faults per
// read then measure its allocator, not the reader.

TEST(ImageIo, DecodingDoesNotFaultInAStagingBufferPerImage) {
  if (testing::kAddressSanitizer)
    GTEST_SKIP() << "AddressSanitizer's allocator ignores mallopt and quarantines freed buffers; "
                    "the normal build runs this test";
  TuneAllocatorForImageBuffers();  // as matfit does: freed image buffers are kept for reuse
  TempDir dir;
  for (const char* name : {"a.jpg", "a.png", "b.png", "a.exr"}) {
    const std::string path = dir / name;
    ImageWriteOptions o;
    o.format = std::string(name) == "b.png"   ? PixelFormat::kUint16
               : std::string(name) == "a.exr" ? PixelFormat::kFloat
                                              : PixelFormat::kUint8;
    ASSERT_TRUE(WriteImage(path, Ramp(512, 512, 3), o).ok());
    ASSERT_TRUE(ReadImageNative(path).ok());  // warm-up: the reader's own buffers
    ASSERT_TRUE(ReadImageNative(path).ok());
    auto faults = [] {
      rusage u{};
      getrusage(RUSAGE_SELF, &u);
      return int64_t(u.ru_minflt);
    };
    const int64_t before = faults();
    for (int r = 0; r < 8; ++r) ASSERT_TRUE(ReadImageNative(path).ok());
    const int64_t per_read = (faults() - before) / 8;
    const int64_t image_pages = int64_t(512) * 512 * 3 *
                                (o.format == PixelFormat::kUint8    ? 1
                                 : o.format == PixelFormat::kUint16 ? 2
                                                                    : 4) /
                                4096;
    EXPECT_LT(per_read, image_pages / 4) << name << ": " << per_read << " faults per read";
  }
}

// Codes written as round(v · max) with a linear transfer, and the pixels with a kept channel at
// the maximum: what ReadImageNative and ReadImageInto must give back, computed here.
template <typename T>
struct WrittenCodes {
  std::vector<std::vector<T>> planes;  // kept channels
  int64_t saturated = 0;
  std::vector<uint8_t> alpha;  // alpha > half range (with a fourth / second channel)
};
template <typename T>
WrittenCodes<T> CodesOf(const Image& img, int keep, int x0, int y0, int w, int h) {
  const float top = float(std::numeric_limits<T>::max());
  WrittenCodes<T> out;
  out.planes.assign(size_t(keep), std::vector<T>(size_t(w) * h));
  auto code = [&](int c, int y, int x) {
    return T(std::lround(std::clamp(img.At(c, y, x), 0.0f, 1.0f) * top));
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool clipped = false;
      for (int c = 0; c < keep; ++c) {
        const T v = code(c, y0 + y, x0 + x);
        out.planes[size_t(c)][size_t(y) * w + x] = v;
        clipped = clipped || v == T(top);
      }
      out.saturated += clipped;
      if (img.channels() == keep + 1)
        out.alpha.push_back(code(keep, y0 + y, x0 + x) > T(top) / 2 ? 1 : 0);
    }
  return out;
}

// An image whose codes cover the range, with saturated samples scattered over every channel
// (a width that is not a multiple of the 256-pixel blocks the splitter works in).
Image Scattered(int w, int h, int ch) {
  Image img(w, h, ch);
  uint32_t state = 12345;
  for (float& v : img.data()) {
    state = state * 1664525u + 1013904223u;
    const uint32_t r = state >> 8;
    v = r % 29 == 0 ? 1.0f : float(r % 65536) / 65535.0f;
  }
  return img;
}

// ReadImageInto gives exactly ReadImageNative's planes, counts and mask, and both the codes the
// file holds (computed independently above): 8- and 16-bit, grey, grey+alpha, RGB, RGBA, whole
// and cropped.
TEST(ImageIo, ReadIntoGivesTheFilesCodesAsReadNativeDoes) {
  TempDir tmp;
  for (int ch : {1, 2, 3, 4})
    for (PixelFormat f : {PixelFormat::kUint8, PixelFormat::kUint16})
      for (bool crop : {false, true}) {
        SCOPED_TRACE(::testing::Message()
                     << ch << " channel(s), " << FormatName(f) << (crop ? ", cropped" : ""));
        const int W = 613, H = 9;
        const Image img = Scattered(W, H, ch);
        const std::string path = tmp / ("s" + std::to_string(ch) + FormatName(f) + ".png");
        ASSERT_TRUE(WriteImage(path, img, {f, TransferFunction::kLinear}).ok());
        ImageReadOptions o;
        o.alpha_mask = true;
        const int x0 = crop ? 3 : 0, y0 = crop ? 2 : 0, w = crop ? 517 : W, h = crop ? 5 : H;
        if (crop) o.col0 = x0, o.cols = w, o.row0 = y0, o.rows = h;
        const int keep = ch >= 3 ? 3 : 1;
        auto check = [&]<typename T>(T) {
          const WrittenCodes<T> want = CodesOf<T>(img, keep, x0, y0, w, h);
          ImageFileInfo ni, ii;
          auto native = ReadImageNative(path, o, &ni);
          ASSERT_TRUE(native.ok()) << native.status().message();
          const std::vector<T>* nat_p = nullptr;
          if constexpr (std::is_same_v<T, uint8_t>)
            nat_p = &native->u8;
          else
            nat_p = &native->u16;
          const std::vector<T>& nat = *nat_p;
          std::vector<std::vector<T>> into(size_t(keep), std::vector<T>(size_t(w) * h, T(7)));
          PlaneTarget t;
          t.width = w, t.height = h, t.channels = keep;
          t.type = std::is_same_v<T, uint8_t> ? SampleType::kUint8 : SampleType::kUint16;
          for (int c = 0; c < keep; ++c) t.planes[c] = into[size_t(c)].data();
          ImageHeader shape;
          auto stored = ReadImageInto(path, o, t, &ii, &shape);
          ASSERT_TRUE(stored.ok()) << stored.status().message();
          ASSERT_TRUE(*stored);
          for (int c = 0; c < keep; ++c) {
            const std::vector<T> plane(nat.begin() + int64_t(c) * w * h,
                                       nat.begin() + int64_t(c + 1) * w * h);
            EXPECT_EQ(plane, want.planes[size_t(c)]) << "native, channel " << c;
            EXPECT_EQ(into[size_t(c)], want.planes[size_t(c)]) << "into, channel " << c;
          }
          EXPECT_EQ(ni.saturated_pixels, want.saturated);
          EXPECT_EQ(ii.saturated_pixels, want.saturated);
          EXPECT_GT(want.saturated, 0);
          EXPECT_EQ(ni.alpha_mask, want.alpha);
          EXPECT_EQ(ii.alpha_mask, want.alpha);
          EXPECT_EQ(shape.width, w);
          EXPECT_EQ(shape.height, h);
          EXPECT_EQ(shape.channels, keep);
          EXPECT_EQ(shape.file_channels, ch);
        };
        if (f == PixelFormat::kUint8)
          check(uint8_t{});
        else
          check(uint16_t{});
      }
}

// Nothing is written into planes that do not match the file: another size, channel count or
// depth, or a transfer function the caller refuses; *shape says what the file holds.
TEST(ImageIo, ReadIntoLeavesMismatchedPlanesUntouched) {
  TempDir tmp;
  const std::string path = tmp / "a.png";
  ASSERT_TRUE(
      WriteImage(path, Ramp(40, 30, 3), {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  std::vector<uint8_t> planes(size_t(3) * 40 * 30, 0xAB);
  const std::vector<uint8_t> before = planes;
  auto target = [&](int w, int h, int ch, SampleType type) {
    PlaneTarget t;
    t.width = w, t.height = h, t.channels = ch, t.type = type;
    for (int c = 0; c < ch; ++c) t.planes[c] = planes.data() + size_t(c) * 40 * 30;
    return t;
  };
  ImageHeader shape;
  ImageFileInfo info;
  for (const PlaneTarget& t :
       {target(40, 29, 3, SampleType::kUint8), target(39, 30, 3, SampleType::kUint8),
        target(40, 30, 1, SampleType::kUint8), target(20, 30, 3, SampleType::kUint16)}) {
    auto r = ReadImageInto(path, {}, t, &info, &shape);
    ASSERT_TRUE(r.ok());
    EXPECT_FALSE(*r);
    EXPECT_EQ(planes, before);
    EXPECT_EQ(shape.width, 40);
    EXPECT_EQ(shape.height, 30);
    EXPECT_EQ(shape.channels, 3);
    EXPECT_EQ(shape.type, SampleType::kUint8);
  }
  bool asked = false;
  auto refused = ReadImageInto(path, {}, target(40, 30, 3, SampleType::kUint8), &info, &shape,
                               [&](const ImageFileInfo& i) {
                                 asked = true;
                                 return i.encoding.transfer == TransferFunction::kLinear;
                               });
  ASSERT_TRUE(refused.ok());
  EXPECT_TRUE(asked);
  EXPECT_FALSE(*refused);  // 8-bit sRGB metadata: not linear
  EXPECT_EQ(planes, before);
  auto taken = ReadImageInto(
      path, {}, target(40, 30, 3, SampleType::kUint8), &info, &shape,
      [](const ImageFileInfo& i) { return i.encoding.transfer == TransferFunction::kSrgb; });
  ASSERT_TRUE(taken.ok());
  EXPECT_TRUE(*taken);
  EXPECT_NE(planes, before);
  // A file whose header is sound but whose pixel data is corrupt (bytes inside IDAT flipped, the
  // length kept: it opens, then fails to decode) leaves the planes as they were, naming the file.
  const std::string bad = tmp / "bad.png";
  {
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t idat = bytes.find("IDAT");
    ASSERT_NE(idat, std::string::npos);
    for (size_t i = idat + 8; i < idat + 40 && i < bytes.size(); ++i) bytes[i] = char(~bytes[i]);
    std::ofstream(bad, std::ios::binary) << bytes;
  }
  std::vector<uint8_t> kept = planes;
  auto broken = ReadImageInto(bad, {}, target(40, 30, 3, SampleType::kUint8), &info, &shape);
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.status().message().rfind("cannot decode image '", 0), 0u)
      << broken.status().message();
  EXPECT_NE(broken.status().message().find("bad.png"), std::string::npos);
  EXPECT_EQ(planes, kept);
}

TEST(ImageIo, UserOverrideWinsOverMetadata) {
  TempDir tmp;
  Image img(4, 4, 3, 0.5f);
  ASSERT_TRUE(WriteImage(tmp / "a.png", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ImageReadOptions o;
  o.color_space = ColorSpaceChoice::kLinear;
  ImageFileInfo info;
  auto back = ReadImage(tmp / "a.png", o, &info);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(info.encoding_reason, "user override");
  // Stored code is the sRGB encoding of 0.5 (188), read back without decoding.
  EXPECT_NEAR(back->At(0, 0, 0), 188 / 255.0, 1e-6);
}

TEST(ImageIo, ManyChannelDataMapsKeepTheirOrder) {
  TempDir tmp;
  Image img(5, 3, 18);
  for (int c = 0; c < 18; ++c)
    for (float& v : img.Plane(c)) v = float(c) - 4.5f;  // negative and > 1: data, not colour
  ASSERT_TRUE(
      WriteImage(tmp / "coef.exr", img, {PixelFormat::kFloat, TransferFunction::kLinear}).ok());
  ImageReadOptions o;
  o.all_channels = true;
  auto back = ReadImage(tmp / "coef.exr", o);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->channels(), 18);
  EXPECT_EQ(back->data(), img.data());
}

TEST(ImageIo, GreyStaysOneChannelAndAlphaIsDropped) {
  TempDir tmp;
  ASSERT_TRUE(WriteImage(tmp / "g.png", Ramp(8, 8, 1), {}).ok());
  ASSERT_TRUE(WriteImage(tmp / "rgba.png", Ramp(8, 8, 4), {}).ok());
  auto g = ReadImage(tmp / "g.png");
  auto rgba = ReadImage(tmp / "rgba.png");
  ASSERT_TRUE(g.ok() && rgba.ok());
  EXPECT_EQ(g->channels(), 1);
  EXPECT_EQ(rgba->channels(), 3);
  EXPECT_NEAR(rgba->At(2, 3, 5), Ramp(8, 8, 4).At(2, 3, 5), 1e-4);
}

TEST(ImageIo, CountsSaturatedPixels) {
  TempDir tmp;
  Image img(10, 10, 3, 0.3f);
  for (int x = 0; x < 10; ++x) img.At(1, 0, x) = 1.5f;  // one row clipped in green
  ASSERT_TRUE(WriteImage(tmp / "s.png", img, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ImageFileInfo info;
  ASSERT_TRUE(ReadImage(tmp / "s.png", {}, &info).ok());
  EXPECT_EQ(info.saturated_pixels, 10);
}

TEST(ImageIo, CountsNonFiniteSamplesInFloatFiles) {
  TempDir tmp;
  Image img(4, 4, 3, 0.3f);
  img.At(0, 1, 1) = std::nanf("");
  img.At(2, 2, 2) = INFINITY;
  ASSERT_TRUE(
      WriteImage(tmp / "n.exr", img, {PixelFormat::kFloat, TransferFunction::kLinear}).ok());
  ImageFileInfo info;
  auto back = ReadImage(tmp / "n.exr", {}, &info);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(info.nonfinite_samples, 2);
}

TEST(ImageIo, WriteIsAtomicAndLeavesNoTemporaries) {
  TempDir tmp;
  ASSERT_TRUE(WriteImage(tmp / "a.png", Ramp(8, 8, 3), {}).ok());
  int files = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) {
    ++files;
    EXPECT_EQ(e.path().filename(), "a.png");
  }
  EXPECT_EQ(files, 1);
  // A folder that does not exist: a clear error, nothing written.
  Status st = WriteImage(tmp / "missing/a.png", Ramp(8, 8, 3), {});
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("missing"), std::string::npos) << st.message();
}

TEST(ImageIo, TruncatedPngIsADataErrorNamingTheFile) {
  TempDir tmp;
  ASSERT_TRUE(WriteImage(tmp / "t.png", Ramp(64, 64, 3), {}).ok());
  const auto size = fs::file_size(tmp / "t.png");
  fs::resize_file(tmp / "t.png", size / 2);
  auto r = ReadImage(tmp / "t.png");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kDataError);
  EXPECT_NE(r.status().message().find("t.png"), std::string::npos) << r.status().message();
}

TEST(ImageIo, GarbageAndMissingFiles) {
  TempDir tmp;
  testing::WriteText(tmp / "x.png", "this is not a png");
  auto r = ReadImage(tmp / "x.png");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("x.png"), std::string::npos);
  auto m = ReadImage(tmp / "nope.png");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace matfit
