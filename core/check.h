// MATFIT_CHECK: invariants that only a bug can break (named so as not to clash with glog).
// MATFIT_DCHECK: the same, compiled out in release builds (hot-path bounds checks).
#pragma once

namespace matfit::detail {
[[noreturn]] void CheckFailed(const char* expr, const char* file, int line, const char* msg);
}

#define MATFIT_CHECK(cond, ...)                                                            \
  do {                                                                                     \
    if (!(cond)) ::matfit::detail::CheckFailed(#cond, __FILE__, __LINE__, "" __VA_ARGS__); \
  } while (0)

#ifdef NDEBUG
#define MATFIT_DCHECK(cond, ...) \
  do {                           \
  } while (0)
#else
#define MATFIT_DCHECK(cond, ...) MATFIT_CHECK(cond, __VA_ARGS__)
#endif
