// Preview cost per model at 512²: the EGL renderer per frame (context and shaders made once),
// per process start (context creation + shader compile + one frame), and the CPU reference
// renderer for the same image. Materials: every ladder model fitted from synthetic wool (64²)
// plus the Blinn–Phong / Cook–Torrance truth materials, as in the agreement test.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <string>

#include "core/parallel.h"
#include "core/synth/materials.h"
#include "core/synth/synth.h"
#include "fit/method.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace {

using namespace matfit;

const char* const kModels[] = {"mean", "lambert",    "heinrich",    "ptm",
                               "hsh3", "lafortune2", "blinn-phong", "cook-torrance"};

const MaterialMaps& Material(int index) {
  static std::map<int, MaterialMaps> cache;
  auto it = cache.find(index);
  if (it != cache.end()) return it->second;
  const std::string name = kModels[index];
  MaterialMaps m;
  if (name == "blinn-phong") {
    m = *synth::MakeMaterial("plastic", 64, 1);
  } else if (name == "cook-torrance") {
    m = *synth::MakeMaterial("plastic-ct", 64, 1);
  } else {
    synth::SynthOptions o;
    o.material = "wool", o.lights = "bonn81", o.size = 64, o.layout = Layout::kLp;
    m = std::move(fit::MakeMethod(name)->Fit(synth::Synthesize(o)->stack, {})->maps);
  }
  return cache[index] = std::move(m);
}

render::RenderOptions Options() {
  render::RenderOptions o;
  o.size = 512;
  o.scene = render::Scene::kSphere;
  o.theta_deg = 40, o.phi_deg = 30, o.ambient = 0.05;
  return o;
}

render::EglRenderer* Egl() {
  static auto r = render::EglRenderer::Create();
  return r.ok() ? r->get() : nullptr;
}

void BM_EglFrame(benchmark::State& state) {
  const MaterialMaps& m = Material(int(state.range(0)));
  if (!Egl()) return state.SkipWithError("EGL unavailable");
  for (auto _ : state) benchmark::DoNotOptimize(Egl()->Render(m, Options()));
  state.SetLabel(kModels[state.range(0)]);
}

void BM_EglProcessStart(benchmark::State& state) {
  const MaterialMaps& m = Material(int(state.range(0)));
  for (auto _ : state) {
    auto r = render::EglRenderer::Create();
    if (!r.ok()) return state.SkipWithError("EGL unavailable");
    benchmark::DoNotOptimize((*r)->Render(m, Options()));
  }
  state.SetLabel(kModels[state.range(0)]);
}

void BM_CpuFrame(benchmark::State& state) {
  const MaterialMaps& m = Material(int(state.range(0)));
  SetNumThreads(int(state.range(1)));
  for (auto _ : state) benchmark::DoNotOptimize(render::RenderCpu(m, Options()));
  SetNumThreads(0);
  state.SetLabel(kModels[state.range(0)]);
}

void Models(benchmark::internal::Benchmark* b) {
  for (int i = 0; i < int(std::size(kModels)); ++i) b->Arg(i);
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}
void ModelsThreads(benchmark::internal::Benchmark* b) {
  for (int i = 0; i < int(std::size(kModels)); ++i) b->Args({i, 1})->Args({i, 2});
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_EglFrame)->Name("egl_frame_512")->Apply(Models);
BENCHMARK(BM_EglProcessStart)->Name("egl_start_and_frame_512")->Apply(Models);
BENCHMARK(BM_CpuFrame)->Name("cpu_frame_512")->Apply(ModelsThreads);

}  // namespace

BENCHMARK_MAIN();
