#include "fit/select_kth.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define MATFIT_SELECT_AVX512 1
#endif

namespace matfit::fit {
namespace {

#ifdef MATFIT_SELECT_AVX512
// Quickselect whose partitions are branch-free vector compressions: eight values at a time are
// compared with the pivot, and the ones below and above it are packed into two scratch buffers
// (three of n + 8 doubles take turns: the part kept becomes the next input, the other two the
// next outputs; `a` is only read, since a full-width store may run 7 doubles past its part).
// Values equal to the pivot are only counted. Small parts finish with the scalar SelectKth.
__attribute__((target("avx512f"))) double SelectAvx512(double* a, int n, int k, double* scratch) {
  double* buffers[3] = {scratch, scratch + (n + 8), scratch + 2 * (n + 8)};
  double* in = a;
  int src = -1;  // in = buffers[src], or a
  int m = n;
  while (m > 16) {
    // The two buffers that are not the input, in order.
    const int b0 = src == 0 ? 1 : 0, b1 = src == 2 ? 1 : 2;
    double* below = buffers[b0];
    double* above = buffers[b1];
    const double pivot = select_detail::MedianOfThree(in, 0, m, std::less<double>());
    const __m512d p = _mm512_set1_pd(pivot);
    int nb = 0, na = 0, i = 0;
    for (; i + 8 <= m; i += 8) {
      const __m512d v = _mm512_loadu_pd(in + i);
      const __mmask8 lt = _mm512_cmp_pd_mask(v, p, _CMP_LT_OQ);
      const __mmask8 gt = _mm512_cmp_pd_mask(v, p, _CMP_GT_OQ);
      _mm512_storeu_pd(below + nb, _mm512_maskz_compress_pd(lt, v));
      _mm512_storeu_pd(above + na, _mm512_maskz_compress_pd(gt, v));
      nb += __builtin_popcount(lt), na += __builtin_popcount(gt);
    }
    if (i < m) {
      const __mmask8 valid = __mmask8((1u << (m - i)) - 1);
      const __m512d v = _mm512_maskz_loadu_pd(valid, in + i);
      const __mmask8 lt = _mm512_cmp_pd_mask(v, p, _CMP_LT_OQ) & valid;
      const __mmask8 gt = _mm512_cmp_pd_mask(v, p, _CMP_GT_OQ) & valid;
      _mm512_storeu_pd(below + nb, _mm512_maskz_compress_pd(lt, v));
      _mm512_storeu_pd(above + na, _mm512_maskz_compress_pd(gt, v));
      nb += __builtin_popcount(lt), na += __builtin_popcount(gt);
    }
    const int equal = m - nb - na;  // ≥ 1: the pivot is one of the values
    if (k < nb) {
      src = b0, m = nb;
    } else if (k < nb + equal) {
      return pivot;
    } else {
      src = b1, m = na, k -= nb + equal;
    }
    in = buffers[src];
  }
  return SelectKth(in, m, k);
}

bool HasAvx512() {
  static const bool has = __builtin_cpu_supports("avx512f");
  return has;
}
#endif

}  // namespace

double SelectKthFinite(double* a, int n, int k, double* scratch) {
#ifdef MATFIT_SELECT_AVX512
  if (n > 32 && HasAvx512()) return SelectAvx512(a, n, k, scratch);
#endif
  (void)scratch;
  return SelectKth(a, n, k);
}

}  // namespace matfit::fit
