// The allocation paths of core/large_page_allocator.h: blocks for the process's operator new
// (app/global_new.cc) and for the stack planes.
#include "core/large_page_allocator.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/core/test_util.h"

namespace matfit {
namespace {

constexpr std::size_t kHugePage = std::size_t(2) << 20;

// "THPeligible:" of the mapping that holds `p` in /proc/self/smaps: 1 when the kernel may back it
// with transparent huge pages. -1 when the field is missing (old kernels, no smaps).
int ThpEligible(const void* p) {
  std::ifstream smaps("/proc/self/smaps");
  const auto a = reinterpret_cast<std::uintptr_t>(p);
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
      inside = a >= lo && a < hi;
      continue;
    }
    if (inside && line.rfind("THPeligible:", 0) == 0) return std::atoi(line.c_str() + 12);
  }
  return -1;
}

bool ThpOff() {
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return mode.empty() || mode.find("[never]") != std::string::npos;
}

TEST(LargePageAllocator, BigBlocksStartOnAHugePageAndAreAdvised) {
  const std::size_t bytes = 3 * kHugePage + 12345;
  void* p = detail::AllocateBlock(bytes);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % kHugePage, 0u);
  std::memset(p, 0x5a, bytes);  // the whole block is usable
  EXPECT_EQ(static_cast<unsigned char*>(p)[bytes - 1], 0x5a);
  if (ThpOff()) {
    std::free(p);
    GTEST_SKIP() << "transparent huge pages are off on this kernel: nothing to advise";
  }
  const int eligible = ThpEligible(p);
  std::free(p);
  if (eligible < 0) GTEST_SKIP() << "this kernel's smaps has no THPeligible field";
  EXPECT_EQ(eligible, 1) << "the block's 2 MiB pages should be advised for huge pages";
}

TEST(LargePageAllocator, SmallBlocksComeFromMallocAndFreeWithFree) {
  for (std::size_t bytes : {std::size_t(0), std::size_t(1), std::size_t(4096), kHugePage - 1}) {
    void* p = detail::AllocateBlock(bytes);
    ASSERT_NE(p, nullptr) << bytes;
    std::memset(p, 1, bytes);
    std::free(p);
  }
}

TEST(LargePageAllocator, ImpossibleBlocksReturnNull) {
  if (testing::kAddressSanitizer)
    GTEST_SKIP() << "AddressSanitizer aborts on impossible sizes by design";
  EXPECT_EQ(detail::AllocateBlock(~std::size_t(0) / 2), nullptr);
}

}  // namespace
}  // namespace matfit
