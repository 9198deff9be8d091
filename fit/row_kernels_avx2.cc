// Row kernels built with -mavx2 -mfma (see fit/CMakeLists.txt); only called after the
// dispatcher has checked the CPU.
#define MATFIT_ROW_KERNELS_NS avx2_isa
#include "fit/row_kernels_impl.h"
