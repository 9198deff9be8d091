// Streaming kernels over contiguous plane segments (a full-width strip of m texels): the inner
// loops of the linear fitters. A call takes a group of up to kMaxRowPlanes planes, so each
// accumulator is loaded and stored once per group rather than once per plane (the accumulators
// of a strip live in L2; the planes stream from memory). Each kernel also folds the samples
// into peak[x] = max(peak, src) (a NaN sample leaves peak unchanged), so a fitter needs no
// separate pass to find black or clipped texels. Dispatched at run time to the widest build the
// CPU runs: AVX-512 (16 lanes), AVX2+FMA (8), or the baseline; MATFIT_KERNELS=avx2 or =generic
// caps the choice.
#pragma once

#include <cstdint>

namespace matfit::fit {

inline constexpr int kMaxRowTerms = 16;
inline constexpr int kMaxRowPlanes = 8;

// acc[j][x] += Σ_p w[p·k + j] · src[p][x] over planes p < planes (≤ kMaxRowPlanes), terms
// j < k (≤ kMaxRowTerms), texels x < m; peak update. Float; the group's products are summed
// from zero before they are added to acc, so over G groups of P planes the rounding grows with
// P + G, not P·G.
void RowAccumulate(const float* const* src, int planes, int64_t m, int k, const float* w,
                   float* const* acc, float* peak);

// Which build the dispatcher chose ("avx512f", "avx2+fma" or "generic"), for benchmark output.
const char* RowKernelIsa();

}  // namespace matfit::fit
