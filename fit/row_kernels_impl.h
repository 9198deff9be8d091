// Bodies of the row kernels (row_kernels.h). Included once per instruction-set build, each
// inside its own namespace MATFIT_ROW_KERNELS_NS, so no inline symbol is shared between the
// builds (an AVX2 copy must never be picked for the generic path by the linker). GCC vector
// extensions, no std templates (those would be such shared symbols). MATFIT_ROW_LANES floats
// per step (default 8; the AVX-512 build takes 16); the generic build lowers each 8-float step
// to two SSE operations.
#include <cstdint>

#include "fit/row_kernels.h"

#ifndef MATFIT_ROW_KERNELS_NS
#error "define MATFIT_ROW_KERNELS_NS before including row_kernels_impl.h"
#endif

// The 32- and 64-byte vector helpers have internal linkage, so the ABI note GCC gives for them in
// the baseline build (no AVX) does not apply (GCC reports it at the end of the unit, so the pragma
// stays on: this header is the whole of the units that include it).
#pragma GCC diagnostic ignored "-Wpsabi"

#ifndef MATFIT_ROW_LANES
#define MATFIT_ROW_LANES 8
#endif

namespace matfit::fit::MATFIT_ROW_KERNELS_NS {
namespace {

constexpr int kLanes = MATFIT_ROW_LANES;
typedef float VF __attribute__((vector_size(4 * MATFIT_ROW_LANES)));  // kLanes floats

inline VF Load(const float* p) {
  VF v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void Store(float* p, VF v) { __builtin_memcpy(p, &v, sizeof v); }
inline VF Max(VF a, VF b) { return a > b ? a : b; }  // b when a is NaN: NaN never wins
inline float MaxS(float a, float b) { return a > b ? a : b; }

template <int K>
void AccumulateK(const float* const* src, int planes, int64_t m, const float* w, float* const* acc,
                 float* peak) {
  int64_t x = 0;
  for (; x + kLanes <= m; x += kLanes) {
    // The group's products are summed from zero, then added to the accumulator: a two-level
    // sum, whose rounding grows with planes-per-group + groups rather than with all planes.
    VF a[K] = {};
    VF pk = Load(peak + x);
    for (int p = 0; p < planes; ++p) {
      const VF v = Load(src[p] + x);
      for (int j = 0; j < K; ++j) a[j] += w[p * K + j] * v;
      pk = Max(v, pk);
    }
    for (int j = 0; j < K; ++j) Store(acc[j] + x, Load(acc[j] + x) + a[j]);
    Store(peak + x, pk);
  }
  for (; x < m; ++x)
    for (int p = 0; p < planes; ++p) {
      const float v = src[p][x];
      for (int j = 0; j < K; ++j) acc[j][x] += w[p * K + j] * v;
      peak[x] = MaxS(v, peak[x]);
    }
}

void AccumulateAny(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak) {
  for (int p = 0; p < planes; ++p) {
    for (int j = 0; j < k; ++j) {
      const float wj = w[p * k + j];
      float* a = acc[j];
      int64_t x = 0;
      for (; x + kLanes <= m; x += kLanes) Store(a + x, Load(a + x) + wj * Load(src[p] + x));
      for (; x < m; ++x) a[x] += wj * src[p][x];
    }
    int64_t x = 0;
    for (; x + kLanes <= m; x += kLanes) Store(peak + x, Max(Load(src[p] + x), Load(peak + x)));
    for (; x < m; ++x) peak[x] = MaxS(src[p][x], peak[x]);
  }
}

}  // namespace

void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak) {
  switch (k) {
    case 1: return AccumulateK<1>(src, planes, m, w, acc, peak);
    case 3: return AccumulateK<3>(src, planes, m, w, acc, peak);
    case 4: return AccumulateK<4>(src, planes, m, w, acc, peak);
    case 6: return AccumulateK<6>(src, planes, m, w, acc, peak);
    case 9: return AccumulateK<9>(src, planes, m, w, acc, peak);
    default: return AccumulateAny(src, planes, m, k, w, acc, peak);
  }
}

}  // namespace matfit::fit::MATFIT_ROW_KERNELS_NS
