// Row kernels for the baseline x86-64 (or any other) instruction set.
#define MATFIT_ROW_KERNELS_NS generic_isa
#include "fit/row_kernels_impl.h"
