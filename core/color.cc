#include "core/color.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>

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

uint8_t LinearToSrgb8Fast(float linear) {
  // bounds[k] (k ≥ 1): the smallest non-negative float v with LinearToSrgb8(v) ≥ k, found by
  // bisection over the bit patterns of [0, 1] (non-negative floats order as their bits).
  static const std::array<float, 256> bounds = [] {
    std::array<float, 256> b{};
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
      std::memcpy(&b[size_t(k)], &hi, sizeof hi);
    }
    return b;
  }();
  int k = 0;
  for (int step = 128; step >= 1; step /= 2) k += bounds[size_t(k + step)] <= linear ? step : 0;
  return uint8_t(k);
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
