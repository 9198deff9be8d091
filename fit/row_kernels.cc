#include "fit/row_kernels.h"

#include <cstdlib>
#include <cstring>

namespace matfit::fit {

#define MATFIT_DECLARE_ROW_KERNELS(ns)                                                       \
  namespace ns {                                                                             \
  void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,  \
                     float* const* acc, float* peak);                                        \
  void RowAccumulateDouble4(const float* const* src, int planes, int64_t m, const double* w, \
                            double* const* acc, float* peak);                                \
  }
MATFIT_DECLARE_ROW_KERNELS(generic_isa)
#ifdef MATFIT_HAVE_AVX2_KERNELS
MATFIT_DECLARE_ROW_KERNELS(avx2_isa)
#endif
#undef MATFIT_DECLARE_ROW_KERNELS

namespace {

bool UseAvx2() {
#ifdef MATFIT_HAVE_AVX2_KERNELS
  // MATFIT_KERNELS=generic forces the baseline build (tests compare the two).
  static const bool yes = [] {
    const char* force = std::getenv("MATFIT_KERNELS");
    if (force && std::strcmp(force, "generic") == 0) return false;
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }();
  return yes;
#else
  return false;
#endif
}

}  // namespace

void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak) {
#ifdef MATFIT_HAVE_AVX2_KERNELS
  if (UseAvx2()) return avx2_isa::RowAccumulate(src, planes, m, k, w, acc, peak);
#endif
  generic_isa::RowAccumulate(src, planes, m, k, w, acc, peak);
}

void RowAccumulateDouble4(const float* const* src, int planes, int64_t m, const double* w,
                          double* const* acc, float* peak) {
#ifdef MATFIT_HAVE_AVX2_KERNELS
  if (UseAvx2()) return avx2_isa::RowAccumulateDouble4(src, planes, m, w, acc, peak);
#endif
  generic_isa::RowAccumulateDouble4(src, planes, m, w, acc, peak);
}

const char* RowKernelIsa() { return UseAvx2() ? "avx2+fma" : "generic"; }

}  // namespace matfit::fit
