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

// acc[j] += Σ_p w[p·k + j] src[p] with k = K at compile time, or (K = 0) k at run time. Each
// group's products are summed from zero, then added to the accumulator: a two-level sum, whose
// rounding grows with planes-per-group + groups rather than with all planes (tails included).
template <int K>
void AccumulateK(const float* const* src, int planes, int64_t m, int k_run, const float* w,
                 float* const* acc, float* peak) {
  const int k = K > 0 ? K : k_run;
  constexpr int kMax = K > 0 ? K : kMaxRowTerms;
  int64_t x = 0;
  for (; x + kLanes <= m; x += kLanes) {
    VF a[kMax] = {};
    VF pk = Load(peak + x);
    for (int p = 0; p < planes; ++p) {
      const VF v = Load(src[p] + x);
      for (int j = 0; j < k; ++j) a[j] += w[p * k + j] * v;
      pk = Max(v, pk);
    }
    for (int j = 0; j < k; ++j) Store(acc[j] + x, Load(acc[j] + x) + a[j]);
    Store(peak + x, pk);
  }
  for (; x < m; ++x) {
    float a[kMax] = {};
    for (int p = 0; p < planes; ++p) {
      const float v = src[p][x];
      for (int j = 0; j < k; ++j) a[j] += w[p * k + j] * v;
      peak[x] = MaxS(v, peak[x]);
    }
    for (int j = 0; j < k; ++j) acc[j][x] += a[j];
  }
}

}  // namespace

void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak) {
  switch (k) {
    case 1: return AccumulateK<1>(src, planes, m, k, w, acc, peak);
    case 3: return AccumulateK<3>(src, planes, m, k, w, acc, peak);
    case 4: return AccumulateK<4>(src, planes, m, k, w, acc, peak);
    case 6: return AccumulateK<6>(src, planes, m, k, w, acc, peak);
    case 9: return AccumulateK<9>(src, planes, m, k, w, acc, peak);
    default: return AccumulateK<0>(src, planes, m, k, w, acc, peak);
  }
}

}  // namespace matfit::fit::MATFIT_ROW_KERNELS_NS
