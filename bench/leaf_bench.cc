// Leaf translucency precompute (METHODS.md §5): the direct reference against the fast method
// (projection first + low-rank thickness expansion of the kernel, FFT convolution) on the synthetic
// leaf, N_L = 128. 256² at 0.2 mm/texel (a 51 mm leaf) for the ratio; 1024² at 0.05 mm/texel (the
// same leaf) for the fast method's absolute time. Run: build/bench/leaf_bench
// --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "core/parallel.h"
#include "leaf/horizon.h"
#include "leaf/synthetic_leaf.h"
#include "leaf/translucency.h"

namespace {

using namespace matfit;

// size² texels at pitch_um micrometres per texel (4× relief: the published-error leaf).
const leaf::SyntheticLeaf& Leaf(int size, int pitch_um) {
  static std::map<std::pair<int, int>, std::unique_ptr<leaf::SyntheticLeaf>> cache;
  auto& s = cache[{size, pitch_um}];
  if (!s) {
    s = std::make_unique<leaf::SyntheticLeaf>();
    leaf::MakeSyntheticLeaf(size, pitch_um / 1000.0, 4.0, s.get());
  }
  return *s;
}

void BM_Reference(benchmark::State& state) {
  SetNumThreads(int(state.range(1)));
  const auto& s = Leaf(int(state.range(0)), int(state.range(2)));
  for (auto _ : state) benchmark::DoNotOptimize(leaf::PrecomputeTranslucencyReference(s.input, {}));
  SetNumThreads(0);
}
void BM_Fast(benchmark::State& state) {
  SetNumThreads(int(state.range(1)));
  const auto& s = Leaf(int(state.range(0)), int(state.range(2)));
  int terms = 0, radius = 0;
  for (auto _ : state) {
    auto r = leaf::PrecomputeTranslucencyFast(s.input, {});
    terms = r->kernel_terms, radius = r->kernel_radius;
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel(std::to_string(terms) + " kernel terms, radius " + std::to_string(radius));
  SetNumThreads(0);
}
// The horizon map is part of a leaf's precompute too (16 slices).
void BM_Horizon(benchmark::State& state) {
  SetNumThreads(int(state.range(1)));
  const auto& s = Leaf(int(state.range(0)), int(state.range(2)));
  for (auto _ : state)
    benchmark::DoNotOptimize(leaf::HorizonMap(s.height_mm, s.input.mm_per_texel, -1, {}));
  SetNumThreads(0);
}

// Args: size, threads, texel pitch in µm.
BENCHMARK(BM_Reference)
    ->Args({256, 2, 100})
    ->Args({256, 2, 200})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(BM_Fast)
    ->Args({256, 2, 100})
    ->Args({256, 2, 200})
    ->Args({256, 1, 100})
    ->Args({1024, 2, 100})
    ->Args({1024, 2, 50})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Horizon)->Args({256, 2, 100})->Args({1024, 2, 100})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
