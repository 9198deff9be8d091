#include "core/parallel.h"

#include <sched.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

namespace matfit {
namespace {

std::atomic<int> g_threads{0};  // 0 = hardware default
thread_local int t_depth = 0;   // ParallelFor ranges this thread is running (nested)
std::mutex g_arena_mutex;
std::shared_ptr<tbb::task_arena> g_arena;
int g_arena_threads = 0;

// The CPUs this process may run on: its affinity mask at start (an MPI launcher binds each rank
// to its cores; taskset, cgroups), else every core. Read once: ParallelFor asks on every call.
int HardwareThreads() {
  static const int n = [] {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
      return int(CPU_COUNT(&set));
    return int(std::max(1u, std::thread::hardware_concurrency()));
  }();
  return n;
}

std::shared_ptr<tbb::task_arena> Arena(int threads) {
  std::lock_guard<std::mutex> lock(g_arena_mutex);
  if (!g_arena || g_arena_threads != threads) {
    g_arena = std::make_shared<tbb::task_arena>(threads);
    g_arena_threads = threads;
  }
  return g_arena;
}

}  // namespace

int NumThreads() {
  const int n = g_threads.load();
  return n > 0 ? n : HardwareThreads();
}

void SetNumThreads(int n) { g_threads.store(n > 0 ? n : 0); }

void ParallelFor(int64_t begin, int64_t end, const std::function<void(int64_t, int64_t)>& fn,
                 int64_t grain) {
  if (end <= begin) return;
  grain = std::max<int64_t>(1, grain);
  const int threads = NumThreads();
  if (threads == 1 || end - begin <= grain) {
    fn(begin, end);
    return;
  }
  // More threads than cores only adds contention (and TBB caps it anyway).
  auto arena = Arena(std::min(threads, HardwareThreads()));
  arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<int64_t>(begin, end, grain),
                      [&](const tbb::blocked_range<int64_t>& r) {
                        struct Depth {  // restored however fn leaves
                          Depth() { ++t_depth; }
                          ~Depth() { --t_depth; }
                        } depth;
                        fn(r.begin(), r.end());
                      });
  });
}

bool InParallelRegion() { return t_depth > 0; }

void ParallelFill(float* p, std::size_t n, float value) {
  constexpr std::size_t kBlock = std::size_t(1) << 18;  // floats: 1 MiB
  if (n < 2 * kBlock || NumThreads() == 1 || InParallelRegion()) {
    std::fill_n(p, n, value);
    return;
  }
  ParallelFor(0, int64_t((n + kBlock - 1) / kBlock), [&](int64_t b0, int64_t b1) {
    const std::size_t s = std::size_t(b0) * kBlock, e = std::min(n, std::size_t(b1) * kBlock);
    std::fill(p + s, p + e, value);
  });
}

}  // namespace matfit
