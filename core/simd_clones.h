// GCC function multi-versioning for the hot texel loops: each marked function is built for the
// baseline ISA and for the x86-64 feature levels v3 (AVX2 + FMA) and, with V4, v4 (AVX-512),
// and the loader picks the best one the CPU supports. Feature levels, not CPU models: an
// "arch=haswell" clone is picked only on Haswell-family CPUs (never on AMD or later Intel
// cores), so it would silently run the baseline build. Other compilers get the baseline.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define MATFIT_CLONES_V3 __attribute__((target_clones("arch=x86-64-v3", "default")))
#define MATFIT_CLONES_V4 \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MATFIT_CLONES_V3
#define MATFIT_CLONES_V4
#endif
