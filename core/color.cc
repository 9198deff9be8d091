#include "core/color.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace matfit {

float SrgbToLinear(float e) {
  const double v = e;
  return float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
}

float LinearToSrgb(float l) {
  const double v = l;
  return float(v <= 0.0031308 ? v * 12.92 : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055);
}

const float* Srgb8ToLinearTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[i] = SrgbToLinear(float(i / 255.0));
    return t;
  }();
  return table.data();
}

uint8_t LinearToSrgb8(float linear) {
  const float e = LinearToSrgb(std::clamp(linear, 0.0f, 1.0f));
  return uint8_t(std::lround(std::clamp(e * 255.0f, 0.0f, 255.0f)));
}

namespace {

// Exact 8-bit sRGB encoding without a pow. bounds[k] (1 ≤ k ≤ 255): the smallest non-negative
// float v with LinearToSrgb8(v) ≥ k, found by bisection over the bit patterns of [0, 1]
// (non-negative floats order as their bits); bounds[256] = +inf. base[i]: the code of i / kBins.
// Codes are at least 3e-4 apart in linear (the narrowest, 1 → 2, near black), wider than a bin
// (1 / 4096 = 2.4e-4), so a bin holds at most one boundary: code(v) = base[i] + (v ≥ next bound).
constexpr int kBins = 4096;
struct Srgb8Tables {
  std::array<float, 257> bounds{};
  std::array<uint8_t, kBins + 1> base{};
  Srgb8Tables() {
    const auto code = [](uint32_t bits) {
      float v;
      std::memcpy(&v, &bits, sizeof v);
      return LinearToSrgb8(v);
    };
    uint32_t one;
    const float f1 = 1.0f;
    std::memcpy(&one, &f1, sizeof one);
    for (int k = 1; k < 256; ++k) {
      uint32_t lo = 0, hi = one;  // code(lo) < k ≤ code(hi)
      while (hi - lo > 1) {
        const uint32_t mid = lo + (hi - lo) / 2;
        (code(mid) >= k ? hi : lo) = mid;
      }
      std::memcpy(&bounds[size_t(k)], &hi, sizeof hi);
    }
    bounds[256] = std::numeric_limits<float>::infinity();
    for (int i = 0; i <= kBins; ++i) base[size_t(i)] = LinearToSrgb8(float(i) / kBins);
  }
};

}  // namespace

void LinearToSrgb8Batch(const float* in, float scale, int n, uint8_t* out) {
  static const Srgb8Tables t;
  const float* bounds = t.bounds.data();
  const uint8_t* base = t.base.data();
  for (int i = 0; i < n; ++i) {
    const float v = scale * in[i];
    const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN → 0; ≥ 1 → bin kBins: 255
    const int k = base[int(c * float(kBins))];
    out[i] = uint8_t(k + (bounds[k + 1] <= c));
  }
}

const SrgbCurveTable& SrgbCurves() {
  static const std::vector<float> tables = [] {
    std::vector<float> t(2 * (SrgbCurveTable::kSteps + 1));
    for (int i = 0; i <= SrgbCurveTable::kSteps; ++i) {
      const double x = double(i) / SrgbCurveTable::kSteps;
      t[size_t(i)] = float(x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4));
      t[size_t(SrgbCurveTable::kSteps + 1 + i)] =
          float(x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055);
    }
    return t;
  }();
  static const SrgbCurveTable curves{tables.data(), tables.data() + SrgbCurveTable::kSteps + 1};
  return curves;
}

uint8_t LinearToSrgb8Fast(float linear) {
  static const Srgb8Tables t;
  if (!(linear > 0)) return 0;  // also NaN
  if (linear >= 1) return 255;
  const int k = t.base[size_t(linear * kBins)];
  return uint8_t(k + (t.bounds[size_t(k + 1)] <= linear));
}

float DecodeToLinear(float stored, const ColorEncoding& enc) {
  switch (enc.transfer) {
    case TransferFunction::kLinear: return stored;
    case TransferFunction::kSrgb: return SrgbToLinear(stored);
    case TransferFunction::kGamma: return stored > 0 ? std::pow(stored, enc.gamma) : stored;
  }
  return stored;
}

std::vector<float> LinearDecodeTable(const ColorEncoding& enc, int bits) {
  const int codes = 1 << bits;
  std::vector<float> lut(codes);
  for (int i = 0; i < codes; ++i) lut[i] = DecodeToLinear(float(i) / float(codes - 1), enc);
  return lut;
}

std::string ColorEncoding::ToString() const {
  switch (transfer) {
    case TransferFunction::kLinear: return "linear";
    case TransferFunction::kSrgb: return "sRGB";
    case TransferFunction::kGamma: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "gamma %.3g", gamma);
      return buf;
    }
  }
  return "?";
}

bool ParseColorSpaceChoice(const std::string& text, ColorSpaceChoice* out) {
  if (text == "auto")
    *out = ColorSpaceChoice::kAuto;
  else if (text == "srgb" || text == "sRGB")
    *out = ColorSpaceChoice::kSrgb;
  else if (text == "linear")
    *out = ColorSpaceChoice::kLinear;
  else
    return false;
  return true;
}

}  // namespace matfit
