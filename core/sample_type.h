// How a LightStack (or a decoded image) stores its samples: float32 for float inputs (EXR, float
// TIFF) and stacks built in memory; the file's own 8/16-bit codes for integer inputs, which a
// per-stack lookup table maps to linear values.
#pragma once

#include <cstdint>

namespace matfit {

enum class SampleType : uint8_t { kFloat32, kUint8, kUint16 };

// Bytes per sample: 4, 1, 2.
inline int SampleBytes(SampleType t) {
  return t == SampleType::kUint8 ? 1 : t == SampleType::kUint16 ? 2 : 4;
}
// Codes of an integer type (256, 65536); 0 for float32.
inline int SampleCodes(SampleType t) {
  return t == SampleType::kUint8 ? 256 : t == SampleType::kUint16 ? 65536 : 0;
}
// "float32", "uint8", "uint16".
inline const char* SampleTypeName(SampleType t) {
  return t == SampleType::kUint8 ? "uint8" : t == SampleType::kUint16 ? "uint16" : "float32";
}

}  // namespace matfit
