// The matfit executable's global operator new/delete: every C++ allocation goes through
// detail::AllocateBlock (core/large_page_allocator.h), so blocks of 2 MiB or more — fitted maps,
// coefficient planes, the viewer's parameter layers — are backed by transparent huge pages. A
// fresh page costs a fault, and on the 2-core test VM a 4 KiB fault costs ≈ 9.6 µs against
// ≈ 0.6 µs per 4 KiB in a 2 MiB fault (docs/benchmarks.md, session 15); an hsh3 fit of
// 512×344×240 took 10.8k faults, 5.9k with this. Libraries' malloc calls are unaffected.
#include <cstdlib>
#include <new>

#include "core/large_page_allocator.h"

void* operator new(std::size_t n) {
  if (void* p = matfit::detail::AllocateBlock(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return ::operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return matfit::detail::AllocateBlock(n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return matfit::detail::AllocateBlock(n);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
