// Stacks at native depth: uint8 / uint16 codes + a code → linear table, read through
// Row/Texels/At/Sample exactly as a float decode of the same files reads.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <span>

#include "core/color.h"
#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/light_stack.h"
#include "core/stack_ops.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

uint32_t Bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// A 37 × 5 × 3 × 2 stack of `type` whose codes run through the whole code range.
LightStack CodeStack(SampleType type, const ColorEncoding& enc) {
  const int bits = type == SampleType::kUint8 ? 8 : 16;
  LightStack s(37, 5, 3, 2, type, LinearDecodeTable(enc, bits));
  const int64_t codes = SampleCodes(type);
  for (int i = 0; i < 2; ++i)
    for (int c = 0; c < 3; ++c)
      for (int64_t p = 0; p < s.plane_size(); ++p) {
        const int64_t code = p == 4 ? codes - 1 : (p * 977 + (i * 3 + c) * 131) % codes;
        if (bits == 8)
          s.Codes<uint8_t>(i, c)[p] = uint8_t(code);
        else
          s.Codes<uint16_t>(i, c)[p] = uint16_t(code);
      }
  return s;
}

TEST(NativeStack, RowAndTexelsDecodeThroughTheTable) {
  const ColorEncoding srgb{TransferFunction::kSrgb, 1.0f}, linear{};
  for (SampleType type : {SampleType::kUint8, SampleType::kUint16})
    for (const ColorEncoding& enc : {srgb, linear}) {
      SCOPED_TRACE(std::string(SampleTypeName(type)) + " " + enc.ToString());
      const LightStack s = CodeStack(type, enc);
      const float max = float(SampleCodes(type) - 1);
      auto code = [&](int i, int c, int64_t p) {
        return type == SampleType::kUint8 ? int(s.Codes<uint8_t>(i, c)[p])
                                          : int(s.Codes<uint16_t>(i, c)[p]);
      };
      std::vector<float> scratch(64, -1.0f);
      for (int i = 0; i < 2; ++i)
        for (int c = 0; c < 3; ++c) {
          // Row y = 3, columns [5, 5 + 30); a texel run spanning rows 1–3.
          const float* row = s.Row(i, c, 3, 5, 30, scratch.data());
          EXPECT_EQ(row, scratch.data());
          for (int x = 0; x < 30; ++x) {
            const int64_t p = 3 * 37 + 5 + x;
            const float want = DecodeToLinear(float(code(i, c, p)) / max, enc);
            ASSERT_EQ(Bits(row[x]), Bits(want)) << "code " << code(i, c, p);
            EXPECT_EQ(Bits(s.At(i, c, 3, 5 + x)), Bits(want));
            EXPECT_EQ(Bits(s.Sample(i, c, p)), Bits(want));
          }
          const float* run = s.Texels(i, c, 30, 50, scratch.data());
          for (int k = 0; k < 50; ++k) ASSERT_EQ(Bits(run[k]), Bits(s.Sample(i, c, 30 + k)));
        }
      // ToFloat holds the same values; its Row points into its planes.
      const LightStack f = s.ToFloat();
      ASSERT_TRUE(f.is_float());
      for (int i = 0; i < 2; ++i)
        for (int c = 0; c < 3; ++c)
          for (int64_t p = 0; p < s.plane_size(); ++p)
            ASSERT_EQ(Bits(f.Sample(i, c, p)), Bits(s.Sample(i, c, p)));
      EXPECT_EQ(f.Row(1, 2, 4, 0, 37, nullptr), f.Plane(1, 2).data() + 4 * 37);
      // The maximum code decodes to 1 (the fits' clip level).
      EXPECT_EQ(s.Sample(0, 0, 4), 1.0f);
    }
}

// Runs of 64 codes and more take the AVX-512 VBMI byte-table decode where the CPU has it, and the
// scalar lookups elsewhere or with MATFIT_KERNELS=generic (ctest runs this test both ways:
// core.native_stack_scalar_decode). Either way the table's floats bit for bit, at every run
// length and start here (the vector body and the scalar tail): a table with NaN, −0, infinity
// and a denormal, a plane of every code in a shuffled order, then the same stack relinearised
// (its byte tables rebuilt).
TEST(NativeStack, LongRunsDecodeEveryCodeBitForBit) {
  std::vector<float> lut(256);
  for (int k = 0; k < 256; ++k) lut[size_t(k)] = float(k) / 255.0f * (k % 2 ? 1.0f : -3.5f);
  lut[3] = std::nanf(""), lut[130] = -0.0f, lut[200] = std::numeric_limits<float>::infinity();
  lut[255] = std::numeric_limits<float>::denorm_min();
  LightStack s(700, 1, 1, 1, SampleType::kUint8, lut);
  for (int64_t p = 0; p < s.plane_size(); ++p) s.Codes<uint8_t>(0, 0)[p] = uint8_t(p * 167 % 256);
  auto check = [&](const std::vector<float>& table) {
    std::vector<float> out(700);
    for (int start : {0, 1, 5, 63, 64, 100})
      for (int n = 1; start + n <= 700; n += n < 140 ? 1 : 37) {
        const float* run = s.Texels(0, 0, start, n, out.data());
        for (int k = 0; k < n; ++k)
          ASSERT_EQ(Bits(run[k]), Bits(table[s.Codes<uint8_t>(0, 0)[size_t(start + k)]]))
              << "start " << start << ", length " << n << ", sample " << k;
      }
  };
  check(lut);
  s.Relinearise({TransferFunction::kSrgb, 1.0f}, "test");
  check(LinearDecodeTable({TransferFunction::kSrgb, 1.0f}, 8));
}

TEST(NativeStack, MemoryBytesCountsTheNativeSize) {
  const size_t samples = 37 * 5 * 3 * 2;
  LightStack f(37, 5, 3, 2);
  EXPECT_EQ(f.MemoryBytes(), samples * 4);
  LightStack u8 = CodeStack(SampleType::kUint8, {});
  EXPECT_EQ(u8.MemoryBytes(), samples + 256 * 4);
  u8.mask.assign(37 * 5, 1);
  EXPECT_EQ(u8.MemoryBytes(), samples + 256 * 4 + 37 * 5);
  EXPECT_EQ(CodeStack(SampleType::kUint16, {}).MemoryBytes(), samples * 2 + 65536 * 4);
}

TEST(NativeStack, FloatAccessOnANativeStackFailsWithAMessage) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  LightStack s = CodeStack(SampleType::kUint8, {});
  const LightStack& cs = s;
  EXPECT_DEATH(s.Plane(0, 0), "native depth");
  EXPECT_DEATH(cs.Plane(0, 0), "native depth");
  EXPECT_DEATH(s.data(), "native depth");
  EXPECT_EQ(s.At(0, 0, 0, 0), s.Sample(0, 0, 0));  // reads work on a non-const native stack
  EXPECT_DEATH(s.Codes<uint16_t>(0, 0), "not uint16");
}

TEST(NativeStack, CropAndSelectKeepTheSampleType) {
  const LightStack s = CodeStack(SampleType::kUint16, {TransferFunction::kSrgb, 1.0f});
  auto crop = CropStack(s, 3, 1, 20, 3);
  ASSERT_TRUE(crop.ok());
  EXPECT_EQ(crop->sample_type(), SampleType::kUint16);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 20; ++x) EXPECT_EQ(crop->At(1, 2, y, x), s.At(1, 2, y + 1, x + 3));
  const LightStack one = SelectImages(s, {1});
  EXPECT_EQ(one.sample_type(), SampleType::kUint16);
  EXPECT_EQ(one.At(0, 1, 2, 9), s.At(1, 1, 2, 9));
  auto half = DownsampleStack(s, 2);  // block means are not codes
  ASSERT_TRUE(half.ok());
  EXPECT_TRUE(half->is_float());
  EXPECT_NEAR(half->At(0, 0, 0, 0),
              (s.At(0, 0, 0, 0) + s.At(0, 0, 0, 1) + s.At(0, 0, 1, 0) + s.At(0, 0, 1, 1)) / 4,
              1e-7);
}

// Written datasets read back at their depth, every sample equal to the float decode of its file.
TEST(NativeStack, DatasetsLoadAtTheirDepthAndMatchTheFloatDecode) {
  synth::SynthOptions so;
  so.material = "plastic";
  so.lights = "dome:6";
  so.size = 19;
  auto r = synth::Synthesize(so);
  ASSERT_TRUE(r.ok());
  for (float& v : std::span<float>(r->stack.data(), size_t(19 * 19 * 3 * 6)))
    v *= 2.0f;  // highlights above full scale: files hold the maximum code there
  for (int bits : {8, 16, 32}) {
    SCOPED_TRACE(bits);
    testing::TempDir dir;
    DatasetWriteOptions wo;
    wo.layout = Layout::kLp;
    wo.bits = bits;
    ASSERT_TRUE(WriteDataset(r->stack, wo, dir.path()).ok());
    auto s = ReadDataset(dir.path());
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    EXPECT_EQ(s->sample_type(), bits == 8    ? SampleType::kUint8
                                : bits == 16 ? SampleType::kUint16
                                             : SampleType::kFloat32);
    EXPECT_EQ(s->MemoryBytes(), size_t(19 * 19 * 3 * 6) * (bits / 8) + s->lut().size() * 4);
    int64_t saturated = 0;
    for (int i = 0; i < s->num_images(); ++i) {
      ImageFileInfo info;
      auto img = ReadImage(s->image_files[i], {}, &info);
      ASSERT_TRUE(img.ok());
      EXPECT_EQ(s->saturated_pixels[i], info.saturated_pixels);
      saturated += info.saturated_pixels;
      for (int c = 0; c < 3; ++c)
        for (int64_t p = 0; p < s->plane_size(); ++p)
          ASSERT_EQ(Bits(s->Sample(i, c, p)), Bits(img->Plane(c)[p]));
    }
    if (bits != 32) {
      EXPECT_GT(saturated, 0) << "the test needs clipped samples";
    }
    // Writing the native stack again gives the same files.
    testing::TempDir again;
    ASSERT_TRUE(WriteDataset(*s, wo, again.path()).ok());
    auto t = ReadDataset(again.path());
    ASSERT_TRUE(t.ok());
    EXPECT_EQ(testing::MaxAbsDiff(*s, *t), 0.0);
  }
}

}  // namespace
}  // namespace matfit
