// The memory-read floor shared by the benchmarks: no kernel that reads a stack can be faster.
#pragma once

#include <cstdint>
#include <cstring>

namespace matfit::bench {

// Memory-read floor: sum every float of the stack once, with 8 independent 64-byte vector
// accumulators, in the widest build the CPU runs (GCC function multi-versioning): no fit that
// reads the stack can be faster than this.
__attribute__((target_clones("avx512f", "avx2", "default"))) inline float SumFloats(
    const float* p, int64_t floats) {
  typedef float V16f __attribute__((vector_size(64)));
  V16f acc[8] = {};
  for (int64_t i = 0; i + 128 <= floats; i += 128)
    for (int j = 0; j < 8; ++j) {
      V16f v;
      std::memcpy(&v, p + i + 16 * j, sizeof v);
      acc[j] += v;
    }
  for (int j = 1; j < 8; ++j) acc[0] += acc[j];
  float sum = 0;
  for (int k = 0; k < 16; ++k) sum += acc[0][k];
  for (int64_t i = floats / 128 * 128; i < floats; ++i) sum += p[i];
  return sum;
}

}  // namespace matfit::bench
