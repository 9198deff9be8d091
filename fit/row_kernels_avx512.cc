// Row kernels built with -mavx512f -mfma, 16 floats per step (see fit/CMakeLists.txt); only
// called after the dispatcher has checked the CPU.
#define MATFIT_ROW_KERNELS_NS avx512_isa
#define MATFIT_ROW_LANES 16
#include "fit/row_kernels_impl.h"
