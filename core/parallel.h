// The one parallel-for of the project. Kernels receive half-open index ranges [begin, end).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

namespace matfit {

// Number of worker threads used by ParallelFor (default: all hardware threads).
int NumThreads();
// n >= 1 sets the thread count; n <= 0 restores the default (all hardware threads).
void SetNumThreads(int n);

// Calls fn(b, e) on disjoint subranges covering [begin, end), each at least `grain` long
// (except the last), in parallel. Runs fn(begin, end) inline when there is one thread or the
// range is no longer than grain (the serial fast path). Blocks until all ranges are done.
void ParallelFor(int64_t begin, int64_t end, const std::function<void(int64_t, int64_t)>& fn,
                 int64_t grain = 1);

// Whether the calling thread is running a ParallelFor range (any level of nesting).
bool InParallelRegion();

// p[0, n) = value. Buffers of 2 MiB or more are filled in 1 MiB blocks on every thread, unless
// the caller is already inside a ParallelFor (the other threads are busy there; a nested fill
// would only add tasks): fresh pages are then first touched — faulted in and zeroed by the
// kernel — by both threads instead of one.
void ParallelFill(float* p, std::size_t n, float value);

}  // namespace matfit
