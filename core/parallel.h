// The one parallel-for of the project. Kernels receive half-open index ranges [begin, end).
#pragma once

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

}  // namespace matfit
