// ProgressFn alone, for headers that only take a callback (core/progress.h has the reporter).
#pragma once

#include <cstdint>
#include <functional>

namespace matfit {

// done units of total; return false to ask the job to stop (cancellation is a return value).
using ProgressFn = std::function<bool(int64_t done, int64_t total)>;

}  // namespace matfit
