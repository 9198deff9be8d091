#include "core/color.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

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
