// Allocator for the big SoA sample buffers (LightStack planes): blocks of 4 MiB or more are
// 2 MiB-aligned and, on Linux, advised for transparent huge pages, so streaming many planes at
// once does not thrash the TLB (the fit kernels read 8 planes 256 KiB+ apart at a time).
// Smaller blocks come from operator new as usual.
#pragma once

#include <cstddef>
#include <new>

namespace matfit {

// Tunes the C allocator for a process that makes and frees many image-sized buffers (decoding
// hundreds of files, encoding maps): freed blocks up to 16 MiB are kept for reuse instead of
// being returned to the kernel and faulted in again page by page. Call once at start-up, before
// threads exist (app/main.cc). Without glibc it does nothing.
void TuneAllocatorForImageBuffers();

namespace detail {
void* AllocateLarge(std::size_t bytes);
void DeallocateLarge(void* p, std::size_t bytes);
// Any block for the process's operator new (app/global_new.cc): from malloc, and blocks of 2 MiB
// or more start on a 2 MiB boundary with their whole 2 MiB pages advised for transparent huge
// pages (a fault then maps 2 MiB instead of 4 KiB; the partial page at the end stays small, so
// resident memory does not grow). Freed with std::free. nullptr when out of memory.
void* AllocateBlock(std::size_t bytes) noexcept;
}  // namespace detail

template <class T>
struct LargePageAllocator {
  using value_type = T;
  LargePageAllocator() = default;
  template <class U>
  LargePageAllocator(const LargePageAllocator<U>&) {}
  T* allocate(std::size_t n) { return static_cast<T*>(detail::AllocateLarge(n * sizeof(T))); }
  void deallocate(T* p, std::size_t n) { detail::DeallocateLarge(p, n * sizeof(T)); }
  // resize(n) leaves new elements default-initialised (uninitialised for numbers): big sample
  // buffers are filled by their producers, often in parallel, so each page is first touched
  // once, by the thread that writes it. assign(n, v) and explicit values still initialise.
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(static_cast<Args&&>(args)...);
  }
  template <class U>
  bool operator==(const LargePageAllocator<U>&) const {
    return true;
  }
};

}  // namespace matfit
