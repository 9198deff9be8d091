// Fit speed on synthetic Bonn-like stacks (81 images). Compare rows of one run: the literal
// per-texel Gauss–Jordan reference against the fast closed form, and lambert.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "bench/read_floor.h"
#include "core/parallel.h"
#include "core/stack_ops.h"
#include "core/synth/synth.h"
#include "fit/diagnostics.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "fit/select_kth.h"

namespace {

using namespace matfit;

const LightStack& Stack(int size) {
  static std::map<int, std::unique_ptr<LightStack>> cache;
  auto& s = cache[size];
  if (!s) {
    synth::SynthOptions o;
    o.material = "wool";
    o.lights = "bonn81";
    o.size = size;
    o.layout = Layout::kBonn;
    s = std::make_unique<LightStack>(std::move(synth::Synthesize(o)->stack));
  }
  return *s;
}

// The same stack as 8-bit sRGB files hold it, at native depth (1 byte per sample + table).
const LightStack& Stack8(int size) {
  static std::map<int, std::unique_ptr<LightStack>> cache;
  auto& s = cache[size];
  if (!s) s = std::make_unique<LightStack>(QuantiseStack(Stack(size), 8));
  return *s;
}

template <StatusOr<fit::FitResult> (*Fn)(const LightStack&, const fit::FitOptions&),
          bool kNative8 = false>
void BM_Fit(benchmark::State& state) {
  const LightStack& s = kNative8 ? Stack8(int(state.range(0))) : Stack(int(state.range(0)));
  SetNumThreads(int(state.range(1)));
  fit::FitOptions o;
  o.tile = int(state.range(2));
  o.heinrich_specular = false;  // the linear solve only: the part the two variants differ in
  for (auto _ : state) {
    auto r = Fn(s, o);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations() * s.texels());
  state.counters["texels/s"] =
      benchmark::Counter(double(s.texels()), benchmark::Counter::kIsIterationInvariantRate);
  SetNumThreads(0);
}

void Args(benchmark::internal::Benchmark* b) {
  // {size, threads, tile}
  for (int size : {64, 128, 256, 512}) b->Args({size, 1, 64});
  for (int tile : {16, 32, 128, 256}) b->Args({256, 1, tile});
  b->Args({256, 2, 64});
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}

using matfit::bench::SumFloats;

void BM_ReadStack(benchmark::State& state) {
  const LightStack& s = Stack(int(state.range(0)));
  const int64_t floats = s.plane_size() * s.channels() * s.num_images();
  for (auto _ : state) {
    const float sum = SumFloats(s.data(), floats);
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * floats * int64_t(sizeof(float)));
}
BENCHMARK(BM_ReadStack)->Name("read_stack")->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime();

// The stack diagnosis every `matfit fit` runs (the tone-curve estimate on a grid of ~2048
// texels, fit/diagnostics.h) on the 8-bit stack; compare with read_stack_u8 in the same run.
void BM_Diagnose(benchmark::State& state) {
  const LightStack& s = Stack8(int(state.range(0)));
  SetNumThreads(int(state.range(1)));
  for (auto _ : state) {
    auto d = fit::DiagnoseStack(s);
    benchmark::DoNotOptimize(d);
  }
  SetNumThreads(0);
}
BENCHMARK(BM_Diagnose)
    ->Name("diagnose_u8")
    ->Args({512, 1})
    ->Args({512, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Memory bandwidth baseline: copy the same stack (N × C × W × H float32) once.
void BM_Memcpy(benchmark::State& state) {
  const LightStack& s = Stack(int(state.range(0)));
  const size_t bytes = size_t(s.plane_size()) * s.channels() * s.num_images() * sizeof(float);
  std::vector<float> dst(bytes / sizeof(float));
  const int threads = int(state.range(1));
  SetNumThreads(threads);
  const int64_t floats = int64_t(dst.size()), chunk = (floats + threads - 1) / threads;
  for (auto _ : state) {
    ParallelFor(0, threads, [&](int64_t b, int64_t e) {
      for (int64_t t = b; t < e; ++t) {
        const int64_t lo = t * chunk, hi = std::min(floats, lo + chunk);
        if (hi > lo) std::memcpy(dst.data() + lo, s.data() + lo, size_t(hi - lo) * sizeof(float));
      }
    });
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  SetNumThreads(0);
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(bytes));
}
BENCHMARK(BM_Memcpy)
    ->Name("memcpy_stack")
    ->Args({256, 1})
    ->Args({256, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The per-texel selections of lambert-robust: the median of 168 |residuals| (its inliers of 240
// lights), on 4096 different random arrays in turn so the branch predictor cannot learn them.
// Arg 0: std::nth_element, 1: SelectKth, 2: SelectKthFinite (fit/select_kth.h). Time per
// selection, ns.
void BM_Median(benchmark::State& state) {
  constexpr int kN = 168, kArrays = 4096;
  std::mt19937 rng(1);
  std::normal_distribution<double> normal;
  std::vector<double> pool(size_t(kN) * kArrays), a(kN),
      scratch(size_t(fit::SelectScratchSize(kN)));
  for (double& v : pool) v = std::abs(normal(rng));
  double acc = 0;
  int64_t t = 0;
  for (auto _ : state) {
    std::copy_n(pool.data() + size_t(t++ % kArrays) * kN, kN, a.data());
    if (state.range(0) == 0) {
      std::nth_element(a.begin(), a.begin() + kN / 2, a.end());
      acc += a[kN / 2];
    } else if (state.range(0) == 1) {
      acc += fit::SelectKth(a.data(), kN, kN / 2);
    } else {
      acc += fit::SelectKthFinite(a.data(), kN, kN / 2, scratch.data());
    }
  }
  benchmark::DoNotOptimize(acc);
  state.SetLabel(state.range(0) == 0   ? "std::nth_element"
                 : state.range(0) == 1 ? "SelectKth"
                                       : "SelectKthFinite");
}
BENCHMARK(BM_Median)->Name("median_168")->DenseRange(0, 2)->Unit(benchmark::kNanosecond);

void NonlinearArgs(benchmark::internal::Benchmark* b) {
  b->Args({64, 1, 64})->Args({128, 1, 64})->Args({128, 2, 64})->Args({256, 2, 64});
  b->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
}

BENCHMARK(BM_Fit<fit::FitBlinnPhong>)->Name("blinn_phong_lm")->Apply(NonlinearArgs);
void RobustArgs(benchmark::internal::Benchmark* b) {
  for (int size : {64, 128, 256}) b->Args({size, 1, 64});
  b->Args({256, 2, 64})->Unit(benchmark::kMillisecond)->UseRealTime();
}
BENCHMARK(BM_Fit<fit::FitLambertRobust>)->Name("lambert_robust")->Apply(RobustArgs);
void ReferenceArgs(benchmark::internal::Benchmark* b) {
  b->Args({64, 1, 64})->Args({256, 1, 64})->Unit(benchmark::kMillisecond)->UseRealTime();
}
StatusOr<fit::FitResult> PtmLinear(const LightStack& s, const fit::FitOptions& o) {
  return fit::FitPtm(s, o);
}
StatusOr<fit::FitResult> PtmSrgb(const LightStack& s, const fit::FitOptions& o) {
  return fit::FitPtm(s, o, /*srgb=*/true);
}
BENCHMARK(BM_Fit<fit::FitHeinrichReference>)->Name("heinrich_reference")->Apply(ReferenceArgs);
BENCHMARK(BM_Fit<fit::FitHeinrich>)->Name("heinrich_fast")->Apply(Args);
BENCHMARK(BM_Fit<fit::FitLambertReference>)->Name("lambert_reference")->Apply(ReferenceArgs);
BENCHMARK(BM_Fit<fit::FitLambert>)->Name("lambert_fast")->Apply(Args);
BENCHMARK(BM_Fit<fit::FitPtmReference>)->Name("ptm_reference")->Apply(ReferenceArgs);
BENCHMARK(BM_Fit<PtmLinear>)->Name("ptm_fast")->Apply(Args);
BENCHMARK(BM_Fit<fit::FitMean>)->Name("mean")->Apply(Args);
// The fast fits on the 8-bit stack held natively (decoded through the table inside the kernels).
void NativeArgs(benchmark::internal::Benchmark* b) {
  b->Args({256, 1, 64})->Args({512, 1, 64})->Args({256, 2, 64});
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}
BENCHMARK(BM_Fit<fit::FitLambert, true>)->Name("lambert_fast_u8")->Apply(NativeArgs);
BENCHMARK(BM_Fit<PtmLinear, true>)->Name("ptm_fast_u8")->Apply(NativeArgs);
// ptm-srgb: the same fit of each sample's sRGB encode (a table lookup per sample).
BENCHMARK(BM_Fit<PtmSrgb, true>)->Name("ptm_srgb_u8")->Apply(NativeArgs);
BENCHMARK(BM_Fit<fit::FitHeinrich, true>)->Name("heinrich_fast_u8")->Apply(NativeArgs);
BENCHMARK(BM_Fit<fit::FitMean, true>)->Name("mean_u8")->Apply(NativeArgs);
BENCHMARK(BM_Fit<fit::FitLambertRobust, true>)->Name("lambert_robust_u8")->Apply(RobustArgs);

}  // namespace

int main(int argc, char** argv) {
  benchmark::AddCustomContext("row_kernels", matfit::fit::RowKernelIsa());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
