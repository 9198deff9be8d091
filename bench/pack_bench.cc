// Pack write costs that are not image encoding: the height map integrated from the normals
// (core/height_from_normals.h), against encoding the same normal map as a 16-bit PNG (a cost the
// pack pays anyway: the ratio is what the height map adds to the write stage). The normal map is
// a fitted-looking surface: a dome, ripples and texel-scale relief noise, inside a disc mask with
// a flagged hole. And the glTF stand-in of a relighting basis (core/pack/gltf_bake.h), eight
// texels at a time against one at a time (the same maps bit for bit), per fitted model.
// Run: build/bench/pack_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// (add --benchmark_enable_random_interleaving=true on a noisy machine).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <random>
#include <vector>

#include "core/height_from_normals.h"
#include "core/image_io.h"
#include "core/pack/gltf_bake.h"
#include "core/parallel.h"
#include "core/synth/synth.h"
#include "fit/method.h"

namespace {

using namespace matfit;

struct NormalCase {
  Image normal;
  std::vector<uint8_t> trusted;
};

// W × H normals of z = dome + ripples + 0.3-texel relief noise (slopes up to ~1), trusted inside
// an ellipse less a flagged 5 % block.
const NormalCase& Case(int w, int h) {
  static std::map<std::pair<int, int>, NormalCase> cache;
  NormalCase& c = cache[{w, h}];
  if (!c.normal.empty()) return c;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.3);
  std::vector<double> z(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double u = (x - 0.5 * w) / w, v = (y - 0.5 * h) / h;
      z[size_t(y) * w + x] = 0.2 * w * std::exp(-8 * (u * u + v * v)) +
                             3 * std::sin(x / 9.0) * std::cos(y / 13.0) + noise(rng);
    }
  c.normal = Image(w, h, 3);
  c.trusted.assign(size_t(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * w + x;
      const double zx = x + 1 < w ? z[p + 1] - z[p] : z[p] - z[p - 1];
      const double zd = y + 1 < h ? z[p + w] - z[p] : z[p] - z[p - w];  // rows down = −y_up
      const double a = -zx, b = zd, len = std::sqrt(a * a + b * b + 1);
      c.normal.Plane(0)[p] = float(a / len), c.normal.Plane(1)[p] = float(b / len),
      c.normal.Plane(2)[p] = float(1 / len);
      const double u = (x - 0.5 * w) / (0.48 * w), v = (y - 0.5 * h) / (0.48 * h);
      const bool hole = std::abs(x - 0.3 * w) < 0.11 * w && std::abs(y - 0.4 * h) < 0.11 * h;
      c.trusted[p] = u * u + v * v < 1 && !hole;
    }
  return c;
}

void BM_IntegrateNormals(benchmark::State& state) {
  SetNumThreads(int(state.range(2)));
  const NormalCase& c = Case(int(state.range(0)), int(state.range(1)));
  HeightResult r;
  for (auto _ : state) {
    r = IntegrateNormals(c.normal, c.trusted);
    benchmark::DoNotOptimize(r.height.Plane(0));
  }
  state.SetLabel(std::to_string(r.iterations) + " iterations, residual " +
                 std::to_string(r.residual));
  SetNumThreads(0);
}

// Baseline: the normal map as a 16-bit PNG in memory (fast effort, as a pack writes it); on 1
// and 2 threads, the writer's strips deflating in parallel.
void BM_EncodeNormalPng16(benchmark::State& state) {
  SetNumThreads(int(state.range(2)));
  const NormalCase& c = Case(int(state.range(0)), int(state.range(1)));
  Image mapped = c.normal;  // [-1, 1] → [0, 1], as the pack stores normals
  for (int k = 0; k < 3; ++k)
    for (size_t p = 0; p < size_t(mapped.width()) * mapped.height(); ++p)
      mapped.Plane(k)[p] = 0.5f * (mapped.Plane(k)[p] + 1);
  for (auto _ : state) benchmark::DoNotOptimize(EncodeImage(mapped, "png", {}));
  SetNumThreads(0);
}

// A basis fitted to the synthetic plastic (256², 240 dome lights): ptm, hsh3 or rbf.
const char* const kBakeModels[] = {"ptm", "hsh3", "rbf"};
const MaterialMaps& BasisMaps(int model) {
  static std::map<int, MaterialMaps> cache;
  if (auto it = cache.find(model); it != cache.end()) return it->second;
  synth::SynthOptions o;
  o.material = "plastic", o.lights = "dome:240", o.size = 256, o.layout = Layout::kLp;
  auto data = synth::Synthesize(o);
  if (!data.ok()) std::abort();
  auto fit = fit::MakeMethod(kBakeModels[model])->Fit(data->stack, {});
  if (!fit.ok()) std::abort();
  return cache[model] = std::move(fit->maps);
}

// Args: model (0 ptm, 1 hsh3, 2 rbf), batched (1) or one texel at a time (0). One thread.
void BM_BakeBasisAsGgx(benchmark::State& state) {
  const MaterialMaps& m = BasisMaps(int(state.range(0)));
  const BakeLanes lanes = state.range(1) ? BakeLanes::kBatched : BakeLanes::kOneByOne;
  SetNumThreads(1);
  for (auto _ : state) benchmark::DoNotOptimize(BakeBasisAsGgx(m, {}, lanes).f0.Plane(0));
  SetNumThreads(0);
  state.SetLabel(std::string(kBakeModels[state.range(0)]) +
                 (state.range(1) ? " batched" : " one by one"));
  state.SetItemsProcessed(int64_t(state.iterations()) * m.width * m.height);
}

BENCHMARK(BM_BakeBasisAsGgx)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Args({2, 1})
    ->ArgNames({"model", "batched"})
    ->Unit(benchmark::kMillisecond);

// Args: width, height, threads.
BENCHMARK(BM_EncodeNormalPng16)
    ->Args({512, 344, 2})
    ->Args({512, 344, 1})
    ->Args({1024, 688, 2})
    ->Args({1024, 688, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IntegrateNormals)
    ->Args({512, 344, 2})
    ->Args({512, 344, 1})
    ->Args({1024, 688, 2})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
