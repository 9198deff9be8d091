// Helpers shared by the core tests.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/dataset/dataset.h"
#include "core/image.h"
#include "core/light_stack.h"

namespace matfit::testing {

// Built with AddressSanitizer (GCC or clang): its allocator ignores mallopt, quarantines freed
// blocks and reports impossible sizes, so tests of allocation behaviour skip themselves.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

// A fresh empty folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// ../shared/data (or $MATFIT_SHARED_DATA); empty when absent.
std::string SharedDataDir();

// Skips the current test with a message when the shared data folder is absent.
#define MATFIT_REQUIRE_SHARED_DATA(sub)                                         \
  const std::string shared_dir = ::matfit::testing::SharedDataDir();            \
  if (shared_dir.empty() || !std::filesystem::exists(shared_dir + "/" + (sub))) \
  GTEST_SKIP() << "shared data '" << (sub) << "' not found (looked in ../shared/data); skipping"

// Largest |a − b| over all samples of two stacks of equal shape.
double MaxAbsDiff(const LightStack& a, const LightStack& b);

void WriteText(const std::string& path, const std::string& text);

// A 12-light 20x16 plaster set (16- or 8-bit) in `layout`, written to dir/name (truth/ too);
// returns the stack written (float).
LightStack WriteSynthSet(const std::string& dir, const std::string& name, Layout layout,
                         int bits = 16);

// A smooth image in (0.05, 0.95) that differs per channel: codec and band-read round trips.
Image WavePattern(int w, int h, int ch);

}  // namespace matfit::testing
