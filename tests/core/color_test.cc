#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/color.h"

namespace matfit {
namespace {

TEST(Srgb, EveryEightBitCodeRoundTrips) {
  const float* table = Srgb8ToLinearTable();
  for (int code = 0; code < 256; ++code) EXPECT_EQ(LinearToSrgb8(table[code]), code) << code;
}

TEST(Srgb, FastEightBitEncodeEqualsThePowForm) {
  // Every 61st float of [0, 1] (16 M values), every code boundary's neighbours, and out of range.
  const float one = 1.0f;
  uint32_t end;
  std::memcpy(&end, &one, sizeof end);
  int64_t mismatches = 0;
  for (uint32_t bits = 0; bits <= end; bits += 61) {
    float v;
    std::memcpy(&v, &bits, sizeof v);
    mismatches += LinearToSrgb8Fast(v) != LinearToSrgb8(v);
  }
  EXPECT_EQ(mismatches, 0);
  const float* table = Srgb8ToLinearTable();
  for (int code = 1; code < 256; ++code) {
    const float mid = 0.5f * (table[code - 1] + table[code]);
    for (float v : {std::nextafter(mid, 0.0f), mid, std::nextafter(mid, 1.0f), table[code]})
      EXPECT_EQ(LinearToSrgb8Fast(v), LinearToSrgb8(v)) << v;
  }
  EXPECT_EQ(LinearToSrgb8Fast(-0.5f), 0);
  EXPECT_EQ(LinearToSrgb8Fast(2.0f), 255);
  EXPECT_EQ(LinearToSrgb8Fast(INFINITY), 255);
  EXPECT_EQ(LinearToSrgb8Fast(NAN), 0);
}

// The batched encode gives LinearToSrgb8Fast's code for every value and scale (16 M floats of
// [0, 1] in blocks, specials, a scale of 0.7 applied before the encode).
TEST(Srgb, BatchedEightBitEncodeEqualsTheFastOne) {
  const float one = 1.0f;
  uint32_t end;
  std::memcpy(&end, &one, sizeof end);
  std::vector<float> in;
  for (uint32_t bits = 0; bits <= end; bits += 61) {
    float v;
    std::memcpy(&v, &bits, sizeof v);
    in.push_back(v);
  }
  for (float v : {-0.5f, 2.0f, float(INFINITY), float(NAN), -0.0f, 1.0f}) in.push_back(v);
  std::vector<uint8_t> out(in.size());
  for (float scale : {1.0f, 0.7f}) {
    for (size_t i = 0; i < in.size(); i += 1000)
      LinearToSrgb8Batch(in.data() + i, scale, int(std::min<size_t>(1000, in.size() - i)),
                         out.data() + i);
    int64_t mismatches = 0;
    for (size_t i = 0; i < in.size(); ++i) mismatches += out[i] != LinearToSrgb8Fast(scale * in[i]);
    EXPECT_EQ(mismatches, 0) << scale;
  }
}

// The table curves (SrgbCurves) against the pow forms: decode ≤ 1e-7, encode ≤ 2e-5, and both
// clamp to [0, 1] (NaN → 0).
TEST(Srgb, TableCurvesAreWithinTheirStatedError) {
  double worst_decode = 0, worst_encode = 0;
  for (int i = 0; i <= 1 << 20; ++i) {
    const float x = float(i) / float(1 << 20);
    worst_decode = std::max(
        worst_decode, double(std::abs(SrgbCurveLookup(SrgbCurves().decode, x) - SrgbToLinear(x))));
    worst_encode = std::max(
        worst_encode, double(std::abs(SrgbCurveLookup(SrgbCurves().encode, x) - LinearToSrgb(x))));
  }
  EXPECT_LE(worst_decode, 1e-7);
  EXPECT_LE(worst_encode, 2e-5);
  EXPECT_EQ(SrgbCurveLookup(SrgbCurves().decode, NAN), 0.0f);
  EXPECT_EQ(SrgbCurveLookup(SrgbCurves().decode, 3.0f), 1.0f);
  EXPECT_EQ(SrgbCurveLookup(SrgbCurves().encode, -1.0f), 0.0f);
}

TEST(Srgb, KnownValues) {
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.21404f, 1e-5);
  EXPECT_NEAR(SrgbToLinear(0.04045f), 0.04045f / 12.92f, 1e-7);  // end of the linear toe
  EXPECT_FLOAT_EQ(SrgbToLinear(1.0f), 1.0f);
  EXPECT_FLOAT_EQ(LinearToSrgb(0.0f), 0.0f);
  EXPECT_NEAR(LinearToSrgb(0.18f), 0.46135f, 1e-4);
}

TEST(Srgb, EncodeDecodeInverse) {
  for (int i = 0; i <= 1000; ++i) {
    const float x = i / 1000.0f;
    EXPECT_NEAR(SrgbToLinear(LinearToSrgb(x)), x, 2e-6f) << x;
  }
}

TEST(ColorEncoding, GammaDecode) {
  const ColorEncoding g22{TransferFunction::kGamma, 2.2f};
  EXPECT_NEAR(DecodeToLinear(0.5f, g22), std::pow(0.5f, 2.2f), 1e-7);
  EXPECT_EQ(g22.ToString(), "gamma 2.2");
  ColorSpaceChoice c;
  EXPECT_TRUE(ParseColorSpaceChoice("linear", &c));
  EXPECT_EQ(c, ColorSpaceChoice::kLinear);
  EXPECT_FALSE(ParseColorSpaceChoice("rec709", &c));
}

}  // namespace
}  // namespace matfit
