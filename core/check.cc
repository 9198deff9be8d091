#include "core/check.h"

#include <cstdio>
#include <cstdlib>

namespace matfit::detail {

void CheckFailed(const char* expr, const char* file, int line, const char* msg) {
  std::fprintf(stderr, "matfit: internal check failed: %s at %s:%d %s\n", expr, file, line, msg);
  std::abort();
}

}  // namespace matfit::detail
