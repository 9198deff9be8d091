// Bodies of the row kernels (row_kernels.h). Included once per instruction-set build, each
// inside its own namespace MATFIT_ROW_KERNELS_NS, so no inline symbol is shared between the
// builds (an AVX2 copy must never be picked for the generic path by the linker). GCC vector
// extensions, no std templates (those would be such shared symbols). 8 floats per step; the
// generic build lowers each step to two SSE operations.
#include <cstdint>

#include "fit/row_kernels.h"

#ifndef MATFIT_ROW_KERNELS_NS
#error "define MATFIT_ROW_KERNELS_NS before including row_kernels_impl.h"
#endif

// The 32-byte vector helpers have internal linkage, so the ABI note GCC gives for them in the
// baseline build (no AVX) does not apply (GCC reports it at the end of the unit, so the pragma
// stays on: this header is the whole of the units that include it).
#pragma GCC diagnostic ignored "-Wpsabi"

namespace matfit::fit::MATFIT_ROW_KERNELS_NS {
namespace {

typedef float V8f __attribute__((vector_size(32)));
typedef double V4d __attribute__((vector_size(32)));
typedef float V4f __attribute__((vector_size(16)));

inline V8f Load(const float* p) {
  V8f v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void Store(float* p, V8f v) { __builtin_memcpy(p, &v, sizeof v); }
inline V4d LoadD(const double* p) {
  V4d v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void StoreD(double* p, V4d v) { __builtin_memcpy(p, &v, sizeof v); }
inline V8f Max(V8f a, V8f b) { return a > b ? a : b; }  // b when a is NaN: NaN never wins
inline float MaxS(float a, float b) { return a > b ? a : b; }

template <int K>
void AccumulateK(const float* const* src, int planes, int64_t m, const float* w, float* const* acc,
                 float* peak) {
  int64_t x = 0;
  for (; x + 8 <= m; x += 8) {
    V8f a[K];
    for (int j = 0; j < K; ++j) a[j] = Load(acc[j] + x);
    V8f pk = Load(peak + x);
    for (int p = 0; p < planes; ++p) {
      const V8f v = Load(src[p] + x);
      for (int j = 0; j < K; ++j) a[j] += w[p * K + j] * v;
      pk = Max(v, pk);
    }
    for (int j = 0; j < K; ++j) Store(acc[j] + x, a[j]);
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
      for (; x + 8 <= m; x += 8) Store(a + x, Load(a + x) + wj * Load(src[p] + x));
      for (; x < m; ++x) a[x] += wj * src[p][x];
    }
    int64_t x = 0;
    for (; x + 8 <= m; x += 8) Store(peak + x, Max(Load(src[p] + x), Load(peak + x)));
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

void RowAccumulateDouble4(const float* const* src, int planes, int64_t m, const double* w,
                          double* const* acc, float* peak) {
  // Mixed precision: the ≤ kMaxRowPlanes products of one group are summed in float registers
  // (relative error ≤ 8·2⁻²⁴ of the group's partial sum), then added to the double accumulators.
  float wf[kMaxRowPlanes * 4];
  for (int q = 0; q < planes * 4; ++q) wf[q] = float(w[q]);
  int64_t x = 0;
  for (; x + 8 <= m; x += 8) {
    V8f a[4] = {};
    V8f pk = Load(peak + x);
    for (int p = 0; p < planes; ++p) {
      const V8f v = Load(src[p] + x);
      for (int j = 0; j < 4; ++j) a[j] += wf[p * 4 + j] * v;
      pk = Max(v, pk);
    }
    for (int j = 0; j < 4; ++j) {
      const V4f lo = {a[j][0], a[j][1], a[j][2], a[j][3]},
                hi = {a[j][4], a[j][5], a[j][6], a[j][7]};
      StoreD(acc[j] + x, LoadD(acc[j] + x) + __builtin_convertvector(lo, V4d));
      StoreD(acc[j] + x + 4, LoadD(acc[j] + x + 4) + __builtin_convertvector(hi, V4d));
    }
    Store(peak + x, pk);
  }
  for (; x < m; ++x)
    for (int p = 0; p < planes; ++p) {
      const float v = src[p][x];
      for (int j = 0; j < 4; ++j) acc[j][x] += w[p * 4 + j] * double(v);
      peak[x] = MaxS(v, peak[x]);
    }
}

}  // namespace matfit::fit::MATFIT_ROW_KERNELS_NS
