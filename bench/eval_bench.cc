// Batched evaluation of fitted maps over a whole stack (issue #16): predicting every light
// (evaluate_all), the reconstruction metrics and the per-texel error bound (confidence), per
// model, against read_stack — one pass over the stack's floats, the floor of anything that
// reads it — in the same run. Ratios: evaluate_all / read_stack and reconstruction /
// read_stack (target ≤ 2 for the linear models). One thread unless the name says /threads:2.
#include <benchmark/benchmark.h>

#include <cstring>
#include <map>
#include <memory>
#include <string>

#include "bench/read_floor.h"
#include "core/model/model.h"
#include "core/parallel.h"
#include "core/synth/synth.h"
#include "fit/confidence.h"
#include "fit/method.h"
#include "fit/metrics.h"

namespace {

using namespace matfit;

const LightStack& Stack() {
  static std::unique_ptr<LightStack> s;
  if (!s) {
    synth::SynthOptions o;
    o.material = "wool";
    o.lights = "bonn81";
    o.size = 256;
    o.layout = Layout::kBonn;
    s = std::make_unique<LightStack>(std::move(synth::Synthesize(o)->stack));
  }
  return *s;
}

const std::vector<std::string> kMethods = {"mean", "lambert",  "ptm",        "hsh2",
                                           "hsh3", "heinrich", "blinn-phong"};

const fit::FitResult& Fitted(int method) {
  static std::map<int, std::unique_ptr<fit::FitResult>> cache;
  auto& r = cache[method];
  if (!r) {
    auto f = fit::MakeMethod(kMethods[size_t(method)])->Fit(Stack(), {});
    r = std::make_unique<fit::FitResult>(std::move(*f));
  }
  return *r;
}

using matfit::bench::SumFloats;  // the same floor as fit_bench's read_stack

void BM_ReadStack(benchmark::State& state) {
  const LightStack& s = Stack();
  const int64_t floats = s.plane_size() * s.channels() * s.num_images();
  for (auto _ : state) benchmark::DoNotOptimize(SumFloats(s.data(), floats));
  state.SetBytesProcessed(int64_t(state.iterations()) * floats * int64_t(sizeof(float)));
}
BENCHMARK(BM_ReadStack)->Name("read_stack")->Unit(benchmark::kMillisecond)->UseRealTime();

// Predictions only: every light × texel × channel into a run buffer, a group of lights at a time
// (BatchEvaluator::EvaluateLights, as the scoring pass uses it).
void BM_EvaluateAll(benchmark::State& state) {
  const LightStack& s = Stack();
  const MaterialMaps& m = Fitted(int(state.range(0))).maps;
  std::vector<Vec3f> lights;
  for (const auto& l : s.lights()) lights.emplace_back(l.direction);
  std::vector<float> out(size_t(kMaxEvalLightGroup) * 3 * kEvalRun);
  for (auto _ : state) {
    const BatchEvaluator eval(m, lights, Vec3f(0, 0, 1));
    float acc = 0;
    for (int64_t p0 = 0; p0 < s.plane_size(); p0 += kEvalRun) {
      const int n = int(std::min<int64_t>(kEvalRun, s.plane_size() - p0));
      for (int i = 0; i < eval.lights(); i += eval.group()) {
        eval.EvaluateLights(i, std::min(eval.group(), eval.lights() - i), p0, n, 3, out.data());
        acc += out[0];
      }
    }
    benchmark::DoNotOptimize(acc);
  }
  state.SetLabel(kMethods[size_t(state.range(0))]);
}

void BM_Reconstruction(benchmark::State& state) {
  const fit::FitResult& f = Fitted(int(state.range(0)));
  SetNumThreads(int(state.range(1)));
  for (auto _ : state) benchmark::DoNotOptimize(fit::Reconstruction(Stack(), f.maps, f.status));
  SetNumThreads(0);
  state.SetLabel(kMethods[size_t(state.range(0))]);
}

void BM_Confidence(benchmark::State& state) {
  const fit::FitResult& f = Fitted(int(state.range(0)));
  const auto method = fit::MakeMethod(kMethods[size_t(state.range(0))]);
  SetNumThreads(int(state.range(1)));
  for (auto _ : state) {
    std::vector<uint8_t> status = f.status;
    benchmark::DoNotOptimize(
        fit::ComputeConfidence(Stack(), f.maps,
                               {method->parameters_per_texel(), method->parameters_per_channel(),
                                method->light_parameters()},
                               &status));
  }
  SetNumThreads(0);
  state.SetLabel(kMethods[size_t(state.range(0))]);
}

void PerModel(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < int(kMethods.size()); ++m) b->Args({m, 1});
  b->Args({2, 2})->ArgNames({"model", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}
BENCHMARK(BM_EvaluateAll)
    ->Name("evaluate_all")
    ->DenseRange(0, int(kMethods.size()) - 1)
    ->ArgName("model")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Reconstruction)->Name("reconstruction")->Apply(PerModel);
BENCHMARK(BM_Confidence)->Name("confidence")->Apply(PerModel);

}  // namespace

BENCHMARK_MAIN();
