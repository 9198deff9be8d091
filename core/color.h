// Transfer functions. Linear values are in [0, 1] relative to full scale.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace matfit {

// IEC 61966-2-1 sRGB decode/encode (piecewise: linear toe below 0.04045 / 0.0031308).
float SrgbToLinear(float encoded);
float LinearToSrgb(float linear);
// Exact decode of all 256 8-bit sRGB codes (table, computed once in double precision).
const float* Srgb8ToLinearTable();
// Nearest 8-bit code of an sRGB-encoded linear value, clamped to [0, 255].
uint8_t LinearToSrgb8(float linear);
// The same code without a pow: a 4096-bin table of codes plus one compare against the next code
// boundary (exact: no bin holds two boundaries). NaN maps to 0.
uint8_t LinearToSrgb8Fast(float linear);
// out[t] = LinearToSrgb8Fast(scale · in[t]) for t < n: the same codes, the tables hoisted out of
// a branch-free loop (clamp, bin, one compare).
void LinearToSrgb8Batch(const float* in, float scale, int n, uint8_t* out);

// sRGB decode / encode of a value clamped to [0, 1] (NaN → 0) by linear interpolation in a
// 4097-point table (SrgbCurveTable): no pow per value, so kernels can run it per sample.
// Absolute error against SrgbToLinear / LinearToSrgb: ≤ 1e-7 decoding (float rounding), ≤ 2e-5
// encoding (at the toe's knee; 0.005 of an 8-bit code).
struct SrgbCurveTable {
  static constexpr int kSteps = 4096;
  const float* decode;  // kSteps + 1 entries: SrgbToLinear(i / kSteps)
  const float* encode;  // LinearToSrgb(i / kSteps)
};
const SrgbCurveTable& SrgbCurves();
inline float SrgbCurveLookup(const float* table, float x) {
  x = x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f;
  const float f = x * float(SrgbCurveTable::kSteps);
  int i = int(f);
  i = i < SrgbCurveTable::kSteps - 1 ? i : SrgbCurveTable::kSteps - 1;
  return table[i] + (f - float(i)) * (table[i + 1] - table[i]);
}

// How the stored values of an image relate to linear light.
enum class TransferFunction {
  kLinear,  // stored value = linear value
  kSrgb,    // IEC 61966-2-1
  kGamma,   // pure power law: linear = stored^gamma (e.g. a PNG gAMA chunk of 1/2.2)
};

struct ColorEncoding {
  TransferFunction transfer = TransferFunction::kLinear;
  float gamma = 1.0f;            // exponent for kGamma, > 0
  std::string ToString() const;  // "linear", "sRGB", "gamma 2.2"
};

// Stored value in [0, 1] → linear.
float DecodeToLinear(float stored, const ColorEncoding& enc);

// Linear value of every code of a `bits`-bit integer file (8 or 16): entry i is
// DecodeToLinear(i / (2^bits − 1), enc), the value the image reader gives that code.
std::vector<float> LinearDecodeTable(const ColorEncoding& enc, int bits);

// What the user asked for on the command line (--color-space auto|srgb|linear).
enum class ColorSpaceChoice { kAuto, kSrgb, kLinear };
bool ParseColorSpaceChoice(const std::string& text, ColorSpaceChoice* out);

}  // namespace matfit
