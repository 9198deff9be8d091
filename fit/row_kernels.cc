#include "fit/row_kernels.h"

#include <cstdlib>
#include <cstring>

namespace matfit::fit {

#define MATFIT_DECLARE_ROW_KERNELS(ns)                                                      \
  namespace ns {                                                                            \
  void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w, \
                     float* const* acc, float* peak);                                       \
  }
MATFIT_DECLARE_ROW_KERNELS(generic_isa)
#ifdef MATFIT_HAVE_AVX2_KERNELS
MATFIT_DECLARE_ROW_KERNELS(avx2_isa)
MATFIT_DECLARE_ROW_KERNELS(avx512_isa)
#endif
#undef MATFIT_DECLARE_ROW_KERNELS

namespace {

enum class Isa { kGeneric, kAvx2, kAvx512 };

// The widest build the CPU runs. MATFIT_KERNELS=generic or =avx2 caps it (the tests compare the
// builds); a cap never selects a build the CPU lacks.
Isa Chosen() {
#ifdef MATFIT_HAVE_AVX2_KERNELS
  static const Isa isa = [] {
    const char* force = std::getenv("MATFIT_KERNELS");
    const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    const bool avx512 = avx2 && __builtin_cpu_supports("avx512f");
    if (force && std::strcmp(force, "generic") == 0) return Isa::kGeneric;
    if (force && std::strcmp(force, "avx2") == 0) return avx2 ? Isa::kAvx2 : Isa::kGeneric;
    return avx512 ? Isa::kAvx512 : avx2 ? Isa::kAvx2 : Isa::kGeneric;
  }();
  return isa;
#else
  return Isa::kGeneric;
#endif
}

}  // namespace

void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak) {
#ifdef MATFIT_HAVE_AVX2_KERNELS
  switch (Chosen()) {
    case Isa::kAvx512: return avx512_isa::RowAccumulate(src, planes, m, k, w, acc, peak);
    case Isa::kAvx2: return avx2_isa::RowAccumulate(src, planes, m, k, w, acc, peak);
    case Isa::kGeneric: break;
  }
#endif
  generic_isa::RowAccumulate(src, planes, m, k, w, acc, peak);
}

const char* RowKernelIsa() {
  switch (Chosen()) {
    case Isa::kAvx512: return "avx512f";
    case Isa::kAvx2: return "avx2+fma";
    case Isa::kGeneric: break;
  }
  return "generic";
}

}  // namespace matfit::fit
