// Baseline for the per-texel nonlinear fit: one ceres::Problem per texel (autodiff cost through
// the same shading functions), against matfit's fixed-size LM on the same texels, same start
// (lambert-robust, computed inside the timed loop for both), same per-texel 7-parameter
// Blinn–Phong model, same Cauchy loss and function tolerance, one thread each. Compare the two
// rows' texels/s.
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <cmath>
#include <memory>

#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/synth/synth.h"
#include "fit/methods.h"
#include "fit/tiny_lm.h"

namespace {

using namespace matfit;

struct Data {
  LightStack stack;
};

const Data& Get(int size) {
  static std::unique_ptr<Data> d;
  if (!d || d->stack.width() != size) {
    synth::SynthOptions o;
    o.material = "plastic";
    o.lights = "bonn81";
    o.size = size;
    o.layout = Layout::kLp;
    d = std::make_unique<Data>();
    d->stack = std::move(synth::Synthesize(o)->stack);
  }
  return *d;
}

// One sample i: three residuals ρ_c max(0, n·l) + k_s (n·h)^e (n·l) − p_c.
struct SampleCost {
  Vec3 l;
  double p[3];
  template <typename T>
  bool operator()(const T* x, T* r) const {
    const Vec3T<T> n = Normalize(Vec3T<T>(x[0], x[1], T(1)));
    const Vec3T<T> lt(T(l.x), T(l.y), T(l.z)), v(T(0), T(0), T(1));
    using std::exp;
    const T lobe = shading::BlinnPhongSpecular(x[5], exp(x[6]), n, lt, v);
    for (int c = 0; c < 3; ++c) r[c] = shading::Lambert(x[2 + c], n, lt) + lobe - T(p[c]);
    return true;
  }
};

void BM_CeresProblemPerTexel(benchmark::State& state) {
  const Data& d = Get(int(state.range(0)));
  const LightStack& s = d.stack;
  double iterations = 0;
  ceres::Solver::Options opt;
  opt.linear_solver_type = ceres::DENSE_QR;
  const fit::FitOptions defaults;
  const fit::LmOptions lm;
  opt.max_num_iterations = lm.max_iterations;
  opt.function_tolerance = lm.function_tolerance;
  opt.logging_type = ceres::SILENT;
  opt.num_threads = 1;
  SetNumThreads(1);
  for (auto _ : state) {
    double total_cost = 0;
    iterations = 0;
    const fit::FitResult init = *fit::FitLambertRobust(s, {});
    for (int64_t p = 0; p < s.plane_size(); ++p) {
      const auto& n0 = init.maps.normal;
      const double nz = std::max<double>(n0.Plane(2)[p], 0.2);
      double x[7] = {n0.Plane(0)[p] / nz,
                     n0.Plane(1)[p] / nz,
                     init.maps.albedo.Plane(0)[p],
                     init.maps.albedo.Plane(1)[p],
                     init.maps.albedo.Plane(2)[p],
                     0.2,
                     std::log(20.0)};
      ceres::Problem problem;
      for (int i = 0; i < s.num_images(); ++i) {
        auto* cost = new SampleCost{s.lights()[i].direction,
                                    {s.Sample(i, 0, p), s.Sample(i, 1, p), s.Sample(i, 2, p)}};
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SampleCost, 3, 7>(cost),
                                 new ceres::CauchyLoss(defaults.robust_scale), x);
      }
      ceres::Solver::Summary summary;
      ceres::Solve(opt, &problem, &summary);
      total_cost += summary.final_cost;
      if (!summary.iterations.empty())  // entry 0 is the start
        iterations += double(summary.iterations.size() - 1);
    }
    benchmark::DoNotOptimize(total_cost);
  }
  SetNumThreads(0);
  state.counters["texels/s"] =
      benchmark::Counter(double(s.texels()), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["iterations/texel"] = iterations / double(s.texels());
}

void BM_TinyLmPerTexel(benchmark::State& state) {
  const Data& d = Get(int(state.range(0)));
  SetNumThreads(1);
  fit::FitOptions o;
  o.per_texel_lobe = true;  // stage 1 only: the same 7-parameter problem per texel
  double iterations = 0;
  for (auto _ : state) {
    auto r = fit::FitBlinnPhong(d.stack, o);
    benchmark::DoNotOptimize(r);
    iterations = r->parameters.at("mean_lm_iterations");
  }
  SetNumThreads(0);
  state.counters["texels/s"] =
      benchmark::Counter(double(d.stack.texels()), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["iterations/texel"] = iterations;
}

BENCHMARK(BM_CeresProblemPerTexel)
    ->Name("ceres_problem_per_texel")
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_TinyLmPerTexel)
    ->Name("tiny_lm_per_texel")
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
