// The native codecs (JPEG, PNG, OpenEXR) against OpenImageIO, loaded as a module: the same
// header, colour space and pixels for the files matfit and other tools write, so image_io
// decides the same whichever backend decoded a file.
#include "core/image_codec.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/image_io.h"
#include "core/parallel.h"
#include "core/version.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

codec::Backend& Oiio() {
  std::string error;
  codec::Backend* b = codec::OpenImageIo(&error);
  if (!b) ADD_FAILURE() << "OpenImageIO module: " << error;
  return *b;
}

size_t SampleBytes(codec::Sample s) {
  return s == codec::Sample::kUint8 ? 1 : s == codec::Sample::kUint16 ? 2 : 4;
}

struct Decoded {
  codec::Header header;
  std::vector<unsigned char> bytes;
};

Decoded Decode(codec::Backend& backend, const std::string& path) {
  std::string error;
  auto r = backend.Open(path, &error);
  EXPECT_TRUE(r) << path << ": " << error;
  if (!r) return {};
  Decoded d{r->header(), {}};
  d.bytes.resize(size_t(d.header.width) * d.header.height * d.header.channels *
                 SampleBytes(d.header.sample));
  EXPECT_TRUE(r->Read(d.bytes.data())) << path << ": " << r->error();
  return d;
}

// Native and OpenImageIO decode `path` alike: size, channels, sample type, colour space, gamma,
// Software tag (where the native reader looks for it) and every pixel byte.
void ExpectSameDecoding(const std::string& path) {
  SCOPED_TRACE(path);
  std::string error;
  ASSERT_TRUE(codec::Native().Open(path, &error)) << "the native backend declined: " << error;
  const Decoded n = Decode(codec::Native(), path), o = Decode(Oiio(), path);
  EXPECT_EQ(n.header.width, o.header.width);
  EXPECT_EQ(n.header.height, o.header.height);
  EXPECT_EQ(n.header.channels, o.header.channels);
  EXPECT_EQ(int(n.header.sample), int(o.header.sample));
  EXPECT_EQ(n.header.color_space, o.header.color_space);
  if (n.header.color_space.rfind("Gamma", 0) == 0) {
    EXPECT_EQ(n.header.gamma, o.header.gamma);
  }
  if (n.header.software_known) {
    EXPECT_EQ(n.header.software, o.header.software);
  }
  EXPECT_TRUE(n.bytes == o.bytes) << "pixels differ";
}

Image Pattern(int w, int h, int ch) { return testing::WavePattern(w, h, ch); }

// Writes `img` through OpenImageIO (as matfit wrote every file before the native codecs).
void WriteWithOiio(const std::string& path, const Image& img, codec::Sample sample, bool srgb) {
  codec::WriteSpec spec;
  spec.width = img.width(), spec.height = img.height(), spec.channels = img.channels();
  spec.sample = sample, spec.srgb = srgb, spec.software = "matfit test";
  spec.strip_rows = img.height();
  std::vector<unsigned char> buf;
  spec.rows = [&](int, int) -> const void* {
    const size_t n = size_t(img.width()) * img.height();
    buf.resize(n * img.channels() * SampleBytes(sample));
    for (size_t p = 0; p < n; ++p)
      for (int c = 0; c < img.channels(); ++c) {
        const float v = std::clamp(img.Plane(c)[p], 0.0f, 1.0f);
        const size_t k = p * img.channels() + c;
        if (sample == codec::Sample::kUint8)
          buf[k] = uint8_t(std::lround(v * 255));
        else if (sample == codec::Sample::kUint16)
          reinterpret_cast<uint16_t*>(buf.data())[k] = uint16_t(std::lround(v * 65535));
        else
          reinterpret_cast<float*>(buf.data())[k] = img.Plane(c)[p];
      }
    return buf.data();
  };
  const std::string ext = fs::path(path).extension().string().substr(1);
  std::string error;
  ASSERT_TRUE(Oiio().Write(ext, spec, path, nullptr, &error)) << path << ": " << error;
}

// A PNG chunk: length, type, data, CRC over type and data.
std::string Chunk(const std::string& type, const std::string& data) {
  std::string c;
  for (int s = 24; s >= 0; s -= 8) c += char((data.size() >> s) & 0xFF);
  const std::string body = type + data;
  const uLong crc = crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()));
  c += body;
  for (int s = 24; s >= 0; s -= 8) c += char((crc >> s) & 0xFF);
  return c;
}

std::string PalettePng() {
  const std::string ihdr("\0\0\0\2\0\0\0\1\x08\x03\0\0\0", 13);  // 2x1, 8-bit, palette
  const std::string plte("\xff\0\0\0\0\xff", 6);                 // red, blue
  const std::string raw("\0\0\1", 3);                            // filter 0, indices 0 1
  uLongf n = compressBound(uLong(raw.size()));
  std::string z(n, '\0');
  compress(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(raw.data()),
           uLong(raw.size()));
  z.resize(n);
  return std::string("\x89PNG\r\n\x1a\n", 8) + Chunk("IHDR", ihdr) + Chunk("PLTE", plte) +
         Chunk("IDAT", z) + Chunk("IEND", "");
}

std::vector<unsigned char> Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(ImageCodec, JpegDecodesAsOpenImageIoDoes) {
  TempDir tmp;
  for (int ch : {1, 3}) {
    const std::string path = tmp / ("c" + std::to_string(ch) + ".jpg");
    WriteWithOiio(path, Pattern(67, 41, ch), codec::Sample::kUint8, true);
    ExpectSameDecoding(path);
    // The same JPEG without its Exif/IPTC segments (a bare JFIF file, as cameras and other
    // tools write): still sRGB for both.
    std::vector<unsigned char> d = Bytes(path), bare(d.begin(), d.begin() + 2);
    size_t i = 2;
    while (i + 4 <= d.size() && d[i] == 0xFF && d[i + 1] != 0xDA) {
      const size_t len = size_t(d[i + 2]) << 8 | d[i + 3];
      if (d[i + 1] != 0xE1 && d[i + 1] != 0xED)
        bare.insert(bare.end(), d.begin() + i, d.begin() + i + 2 + len);
      i += 2 + len;
    }
    bare.insert(bare.end(), d.begin() + i, d.end());
    ASSERT_LT(bare.size(), d.size());
    const std::string bare_path = tmp / ("bare" + std::to_string(ch) + ".jpg");
    std::ofstream(bare_path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bare.data()), std::streamsize(bare.size()));
    ExpectSameDecoding(bare_path);
  }
}

TEST(ImageCodec, PngDecodesAsOpenImageIoDoes) {
  TempDir tmp;
  for (int ch : {1, 3})  // grey+alpha and RGBA go to OpenImageIO (see below)
    for (auto sample : {codec::Sample::kUint8, codec::Sample::kUint16})
      for (bool srgb : {false, true}) {
        const std::string name = "c" + std::to_string(ch) + "_" +
                                 std::to_string(SampleBytes(sample) * 8) +
                                 (srgb ? "_srgb" : "_lin");
        // Written by OpenImageIO and by the native writer: both read alike by both readers.
        WriteWithOiio(tmp / (name + "_oiio.png"), Pattern(33, 20, ch), sample, srgb);
        ExpectSameDecoding(tmp / (name + "_oiio.png"));
        ImageWriteOptions o;
        o.format = sample == codec::Sample::kUint8 ? PixelFormat::kUint8 : PixelFormat::kUint16;
        o.transfer = srgb ? TransferFunction::kSrgb : TransferFunction::kLinear;
        ASSERT_TRUE(WriteImage(tmp / (name + ".png"), Pattern(33, 20, ch), o).ok());
        ExpectSameDecoding(tmp / (name + ".png"));
      }
}

TEST(ImageCodec, RealPngsDecodeAsOpenImageIoDoes) {
  const fs::path sheet = fs::path(MATFIT_SHARED_DATA) / "leaf-sheet";
  if (!fs::is_directory(sheet)) GTEST_SKIP() << "shared data absent: " << sheet;
  int n = 0;
  for (const auto& e : fs::directory_iterator(sheet))
    if (e.path().extension() == ".png" && n++ < 4) ExpectSameDecoding(e.path().string());
  EXPECT_GT(n, 0);
}

TEST(ImageCodec, ExrDecodesAsOpenImageIoDoes) {
  TempDir tmp;
  for (int ch : {1, 2, 3, 4, 18})
    for (auto format : {PixelFormat::kHalf, PixelFormat::kFloat}) {
      const std::string name =
          "c" + std::to_string(ch) + (format == PixelFormat::kHalf ? "h" : "f");
      Image img = Pattern(29, 13, ch);
      img.Plane(0)[5] = -3.5f;  // data maps hold any value
      ImageWriteOptions o{format, TransferFunction::kLinear, ch == 3};
      ASSERT_TRUE(WriteImage(tmp / (name + ".exr"), img, o).ok());
      ExpectSameDecoding(tmp / (name + ".exr"));
      WriteWithOiio(tmp / (name + "_oiio.exr"), img,
                    format == PixelFormat::kHalf ? codec::Sample::kHalf : codec::Sample::kFloat,
                    false);
      ExpectSameDecoding(tmp / (name + "_oiio.exr"));
      if (format == PixelFormat::kFloat) {  // float maps round-trip exactly
        ImageReadOptions ro;
        ro.all_channels = true;
        auto back = ReadImage(tmp / (name + ".exr"), ro);
        ASSERT_TRUE(back.ok()) << back.status().ToString();
        EXPECT_EQ(back->data(), img.data());
      }
    }
}

TEST(ImageCodec, UnusualFilesAreLeftToOpenImageIo) {
  TempDir tmp;
  // A palette PNG and a TIFF: the native backend declines them (no error), image_io reads them
  // through the module.
  const std::string tif = tmp / "a.tif";
  ASSERT_TRUE(
      WriteImage(tif, Pattern(8, 6, 3), {PixelFormat::kUint16, TransferFunction::kLinear}).ok());
  std::string error;
  EXPECT_FALSE(codec::Native().Open(tif, &error));
  EXPECT_EQ(error, "");
  auto img = ReadImage(tif);
  ASSERT_TRUE(img.ok()) << img.status().ToString();
  EXPECT_EQ(img->width(), 8);
  // A PNG with alpha goes to OpenImageIO (colours as stored, not premultiplied).
  const std::string rgba = tmp / "rgba.png";
  ASSERT_TRUE(
      WriteImage(rgba, Pattern(8, 6, 4), {PixelFormat::kUint8, TransferFunction::kLinear}).ok());
  EXPECT_FALSE(codec::Native().Open(rgba, &error));
  EXPECT_EQ(error, "");
  ASSERT_TRUE(ReadImage(rgba).ok());
  // PNG colour type 3 (palette): 2x1 pixels, red then blue.
  const std::string pal = tmp / "pal.png";
  std::ofstream(pal, std::ios::binary) << PalettePng();
  EXPECT_FALSE(codec::Native().Open(pal, &error));
  EXPECT_EQ(error, "");
  auto p = ReadImage(pal);
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  ASSERT_EQ(p->channels(), 3);
  EXPECT_GT(p->Plane(0)[0], 0.99f);  // red
  EXPECT_GT(p->Plane(2)[1], 0.99f);  // blue
}

TEST(ImageCodec, BrokenFilesNameTheirTrouble) {
  TempDir tmp;
  for (const char* name : {"t.jpg", "t.png", "t.exr"}) {
    const std::string path = tmp / name;
    const bool exr = std::strcmp(name, "t.exr") == 0;
    ASSERT_TRUE(WriteImage(path, Pattern(64, 64, 3),
                           {exr                               ? PixelFormat::kFloat
                            : std::strcmp(name, "t.jpg") == 0 ? PixelFormat::kUint8
                                                              : PixelFormat::kUint16,
                            TransferFunction::kSrgb})
                    .ok());
    std::vector<unsigned char> d = Bytes(path);
    d.resize(d.size() / 2);  // truncated
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size()));
    auto r = ReadImage(path);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_NE(r.status().message().find(name), std::string::npos) << r.status().ToString();
  }
}

TEST(ImageCodec, PngWithoutItsEndChunkKeepsItsPixels) {
  TempDir tmp;
  const std::string full = tmp / "full.png", cut = tmp / "cut.png";
  ASSERT_TRUE(
      WriteImage(full, Pattern(16, 9, 3), {PixelFormat::kUint16, TransferFunction::kLinear}).ok());
  std::vector<unsigned char> d = Bytes(full);
  d.resize(d.size() - 12);  // IEND: length, type, CRC
  std::ofstream(cut, std::ios::binary)
      .write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size()));
  auto a = ReadImage(full), b = ReadImage(cut);
  ASSERT_TRUE(a.ok() && b.ok()) << b.status().ToString();
  EXPECT_EQ(a->data(), b->data());
}

// A JPEG whose header claims far more pixels than its bytes can code is refused before any pixel
// memory is allocated (a decompression bomb's cheap form), naming the file and the claim.
TEST(ImageCodec, JpegHeaderClaimingMoreThanItsBytesIsRefused) {
  TempDir tmp;
  const std::string path = tmp / "bomb.jpg";
  ASSERT_TRUE(
      WriteImage(path, Pattern(16, 16, 3), {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  std::vector<unsigned char> d = Bytes(path);
  size_t i = 2;  // find SOF0 and set its size to 30000x30000
  while (i + 9 < d.size() && !(d[i] == 0xFF && (d[i + 1] == 0xC0 || d[i + 1] == 0xC2)))
    i += 2 + (size_t(d[i + 2]) << 8 | d[i + 3]);
  ASSERT_LT(i + 9, d.size());
  d[i + 5] = d[i + 7] = 30000 >> 8;
  d[i + 6] = d[i + 8] = 30000 & 0xFF;
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size()));
  auto h = ReadImageHeader(path);
  ASSERT_FALSE(h.ok());
  EXPECT_NE(h.status().message().find("bomb.jpg"), std::string::npos) << h.status().ToString();
  EXPECT_NE(h.status().message().find("30000x30000"), std::string::npos) << h.status().ToString();
  // The untouched file of the same bytes reads.
  ASSERT_TRUE(
      WriteImage(path, Pattern(16, 16, 3), {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  EXPECT_TRUE(ReadImageHeader(path).ok());
}

// PNG chunks and EXR header attributes whose declared length exceeds the file are refused before
// libpng/OpenEXR allocate that length (both allocate first: a 2 KB file could ask for 800 MB).
TEST(ImageCodec, ChunksAndAttributesLongerThanTheFileAreRefused) {
  TempDir tmp;
  const std::string png = tmp / "long.png", exr = tmp / "long.exr";
  ASSERT_TRUE(
      WriteImage(png, Pattern(8, 6, 3), {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  ASSERT_TRUE(
      WriteImage(exr, Pattern(8, 6, 3), {PixelFormat::kFloat, TransferFunction::kLinear}).ok());
  auto patch = [](const std::string& path, const std::string& marker, size_t offset,
                  std::vector<unsigned char> bytes) {
    std::vector<unsigned char> d = Bytes(path);
    const auto it = std::search(d.begin(), d.end(), marker.begin(), marker.end());
    ASSERT_NE(it, d.end()) << marker;
    std::copy(bytes.begin(), bytes.end(), it + std::ptrdiff_t(offset));
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size()));
  };
  // The tEXt chunk's length field (4 bytes before its type): 0x33000000 bytes.
  const std::string text("tEXt");
  std::vector<unsigned char> d = Bytes(png);
  const auto t = std::search(d.begin(), d.end(), text.begin(), text.end());
  ASSERT_NE(t, d.end());
  const size_t at = size_t(t - d.begin()) - 4;
  d[at] = 0x33, d[at + 1] = d[at + 2] = d[at + 3] = 0;
  std::ofstream(png, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size()));
  auto p = ReadImage(png);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.status().message().find("long.png"), std::string::npos) << p.status().ToString();
  EXPECT_NE(p.status().message().find("'tEXt' chunk declares 855638016 bytes"), std::string::npos)
      << p.status().ToString();
  // The Software attribute's size (after "Software\0string\0"): 0x7fffffff bytes.
  patch(exr, std::string("Software\0string\0", 16), 16, {0xff, 0xff, 0xff, 0x7f});
  auto e = ReadImage(exr);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.status().message().find("long.exr"), std::string::npos) << e.status().ToString();
  EXPECT_NE(e.status().message().find("'Software' (string) declares 2147483647 bytes"),
            std::string::npos)
      << e.status().ToString();
}

TEST(ImageCodec, EncodedPngInMemoryIsTheFile) {
  TempDir tmp;
  const Image img = Pattern(21, 11, 3);
  const ImageWriteOptions o{PixelFormat::kUint8, TransferFunction::kSrgb};
  auto bytes = EncodeImage(img, "png", o);
  ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
  ASSERT_TRUE(WriteImage(tmp / "f.png", img, o).ok());
  const std::vector<unsigned char> file = Bytes(tmp / "f.png");
  EXPECT_EQ(*bytes, std::string(file.begin(), file.end()));
}

// The integer formats' codes: round(v · max) with ties away from zero (std::lround) for linear
// 8- and 16-bit files, round(255 · sRGB(v)) for 8-bit sRGB, clamped; NaN gives 0. Values on
// every tie of the 8-bit and of the 16-bit range, just beside them, outside [0, 1] and NaN, read
// back code by code.
TEST(ImageCodec, IntegerCodesRoundAsLroundDoes) {
  TempDir tmp;
  std::vector<float> values = {
      -1.0f, -0.0f, 0.0f, 1.0f, 2.0f, std::nanf(""), std::numeric_limits<float>::infinity()};
  for (int k = 0; k < 65535; ++k)
    for (float top : {255.0f, 65535.0f})
      for (float d : {-1e-4f, 0.0f, 1e-4f})
        if (k < 255 || top > 255.0f) values.push_back((float(k) + 0.5f + d) / top);
  for (int k = 0; k < 4096; ++k) values.push_back(float(k) * 37.0f / 65535.0f / 3.0f);
  values.resize((values.size() + 1023) / 1024 * 1024, 0.0f);  // 1024 × rows
  const int w = int(values.size());
  Image img(1024, w / 1024, 1);
  for (int x = 0; x < w; ++x) img.Plane(0)[x] = values[size_t(x)];
  struct Case {
    PixelFormat format;
    TransferFunction transfer;
    float top;
  };
  for (const Case& c : {Case{PixelFormat::kUint8, TransferFunction::kLinear, 255.0f},
                        Case{PixelFormat::kUint16, TransferFunction::kLinear, 65535.0f},
                        Case{PixelFormat::kUint8, TransferFunction::kSrgb, 255.0f}}) {
    const fs::path f = tmp / "codes.png";
    ASSERT_TRUE(WriteImage(f, img, {c.format, c.transfer}).ok());
    ImageReadOptions ro;
    ro.color_space = ColorSpaceChoice::kLinear;  // the stored codes / max, undecoded
    auto back = ReadImage(f, ro);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    for (int x = 0; x < w; ++x) {
      const float v = values[size_t(x)];
      long want;
      if (c.transfer == TransferFunction::kSrgb)
        want = LinearToSrgb8(v);
      else
        want = std::isnan(v) ? 0 : std::lround(std::clamp(v, 0.0f, 1.0f) * c.top);
      const long got = std::lround(back->Plane(0)[x] * c.top);
      ASSERT_EQ(got, want) << "value " << v << " (x " << x << "), top " << c.top
                           << (c.transfer == TransferFunction::kSrgb ? ", sRGB" : "");
    }
  }
}

// The PNG writer deflates strips of rows in parallel into one zlib stream
// (core/codec_png_write.cc). For images of one strip, of many (more than one wave of eight), of
// rows longer than a strip, 8 and 16 bits, grey and RGB, level 1 and 6: the file is the same on 1
// and 2 threads; every chunk's CRC holds; the chunks are IHDR, sRGB or gAMA, two tEXt, IDAT…, IEND;
// the IDATs inflate (zlib checks the Adler-32) to exactly the unfiltered rows of the expected
// codes; and libpng and OpenImageIO read the file alike.
TEST(ImageCodec, PngStripsDeflatedInParallelMakeOneStream) {
  TempDir tmp;
  struct Case {
    int w, h, ch;
    PixelFormat format;
    TransferFunction transfer;
    bool compact;
    int min_idat;  // IDAT chunks: one per strip
  };
  const Case cases[] = {
      {1, 1, 1, PixelFormat::kUint8, TransferFunction::kLinear, false, 1},
      {512, 344, 3, PixelFormat::kUint16, TransferFunction::kLinear, false, 9},  // 42 rows a strip
      {2000, 300, 3, PixelFormat::kUint8, TransferFunction::kSrgb, false, 15},   // two waves
      {50000, 3, 3, PixelFormat::kUint8, TransferFunction::kLinear, false, 3},   // a row > a strip
      {333, 517, 1, PixelFormat::kUint16, TransferFunction::kLinear, true, 3},
  };
  // Wider than libpng reads back: refused with the limit, not written.
  auto wide = EncodeImage(Image(1000001, 1, 1), "png", {PixelFormat::kUint8});
  ASSERT_FALSE(wide.ok());
  EXPECT_NE(wide.status().message().find("1000000"), std::string::npos) << wide.status().message();
  for (const Case& c : cases) {
    SCOPED_TRACE(std::to_string(c.w) + "x" + std::to_string(c.h) + "x" + std::to_string(c.ch));
    Image img = Pattern(c.w, c.h, c.ch);
    img.Plane(0)[0] = -1.0f, img.Plane(c.ch - 1)[int64_t(c.w) * c.h - 1] = 2.0f;  // clamped
    const ImageWriteOptions o{c.format, c.transfer, c.compact};
    SetNumThreads(1);
    auto one = EncodeImage(img, "png", o);
    SetNumThreads(2);
    auto two = EncodeImage(img, "png", o);
    SetNumThreads(0);
    ASSERT_TRUE(one.ok() && two.ok());
    EXPECT_TRUE(*one == *two) << "the file depends on the thread count";
    const std::string& f = *two;
    ASSERT_EQ(f.compare(0, 8, "\x89PNG\r\n\x1a\n"), 0);
    std::vector<std::string> types;
    std::string z, text;
    int idat = 0;
    size_t p = 8;
    while (p + 12 <= f.size()) {
      auto be32 = [&](size_t at) {
        return uint32_t(uint8_t(f[at])) << 24 | uint32_t(uint8_t(f[at + 1])) << 16 |
               uint32_t(uint8_t(f[at + 2])) << 8 | uint32_t(uint8_t(f[at + 3]));
      };
      const uint32_t n = be32(p);
      ASSERT_LE(p + 12 + n, f.size());
      const std::string type = f.substr(p + 4, 4);
      EXPECT_EQ(crc32(0, reinterpret_cast<const Bytef*>(f.data() + p + 4), n + 4), be32(p + 8 + n))
          << type << " chunk's CRC";
      if (type == "IDAT") z += f.substr(p + 8, n), ++idat;
      if (type == "tEXt") text += f.substr(p + 8, n) + '|';
      if (type == "sRGB") {
        EXPECT_EQ(f.substr(p + 8, n), std::string(1, '\0'));  // perceptual
      }
      if (type == "gAMA") {
        EXPECT_EQ(be32(p + 8), 100000u);  // 1.0
      }
      if (type == "IHDR") {
        EXPECT_EQ(be32(p + 8), uint32_t(c.w));
        EXPECT_EQ(be32(p + 12), uint32_t(c.h));
        EXPECT_EQ(int(uint8_t(f[p + 16])), c.format == PixelFormat::kUint16 ? 16 : 8);
        EXPECT_EQ(int(uint8_t(f[p + 17])), c.ch == 1 ? 0 : 2);  // grey, RGB
      }
      if (types.empty() || types.back() != type || type != "IDAT") types.push_back(type);
      p += 12 + n;
    }
    EXPECT_EQ(p, f.size()) << "bytes after IEND";
    EXPECT_EQ(text, std::string("oiio:ColorSpace\0", 16) +
                        (c.transfer == TransferFunction::kSrgb ? "sRGB" : "Linear") + "|" +
                        std::string("Software\0", 9) + "matfit " + kMatfitVersion + "|");
    const std::string colour = c.transfer == TransferFunction::kSrgb ? "sRGB" : "gAMA";
    EXPECT_EQ(types, (std::vector<std::string>{"IHDR", colour, "tEXt", "tEXt", "IDAT", "IEND"}));
    EXPECT_GE(idat, c.min_idat) << "strips";
    // The rows as they must be: filter byte 0, then the codes (16-bit big-endian).
    const int bytes = c.format == PixelFormat::kUint16 ? 2 : 1;
    const float top = bytes == 2 ? 65535.0f : 255.0f;
    std::string want;
    for (int y = 0; y < c.h; ++y) {
      want += '\0';
      for (int x = 0; x < c.w; ++x)
        for (int ch = 0; ch < c.ch; ++ch) {
          const float v = img.Plane(ch)[int64_t(y) * c.w + x];
          const long code = c.transfer == TransferFunction::kSrgb
                                ? long(LinearToSrgb8(v))
                                : std::lround(std::clamp(v, 0.0f, 1.0f) * top);
          if (bytes == 2) want += char(code >> 8);
          want += char(code & 0xFF);
        }
    }
    std::string raw(want.size() + 1, '\0');
    uLongf got = uLongf(raw.size());
    uLong used = uLong(z.size());  // uncompress2: the stream must end where the data ends
    ASSERT_EQ(uncompress2(reinterpret_cast<Bytef*>(raw.data()), &got,
                          reinterpret_cast<const Bytef*>(z.data()), &used),
              Z_OK);
    EXPECT_EQ(used, uLong(z.size())) << "bytes after the zlib stream";
    raw.resize(got);
    EXPECT_TRUE(raw == want) << "the rows inflate to other bytes";
    if (int64_t(c.w) * c.h <= 600000) {
      const fs::path file = tmp / "strips.png";
      std::ofstream(file, std::ios::binary) << f;
      ExpectSameDecoding(file);
    }
  }
}

}  // namespace
}  // namespace matfit
