#include "fit/metrics.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"
#include "fit/residual_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define MATFIT_METRIC_CLONES __attribute__((target_clones("arch=haswell", "default")))
#else
#define MATFIT_METRIC_CLONES
#endif

namespace matfit::fit {

namespace {

int64_t Runs(int64_t texels) { return (texels + kEvalRun - 1) / kEvalRun; }

// Σ_t [ok_t] (obs_t − I · pred_t)² over a run: the difference in float (8 lanes; its rounding
// is relative to each sample), its square summed in double in two 4-lane accumulators (the
// compiler will not reassociate a scalar double sum), reduced in a fixed order so the result
// does not depend on the ISA clone. `ok` holds 1.0f for texels to score, 0 elsewhere: a
// select, so NaN outside scored texels never enters the sum.
typedef double V4d __attribute__((vector_size(32)));
typedef float V4f __attribute__((vector_size(16)));
typedef float V8f __attribute__((vector_size(32)));

// 8 differences squared into two double accumulators.
__attribute__((always_inline)) inline void Accumulate8(const float* obs, const float* pred,
                                                       float intensity, const float* ok, V4d* a,
                                                       V4d* b) {
  V8f o, p, w;
  std::memcpy(&o, obs, sizeof o), std::memcpy(&p, pred, sizeof p), std::memcpy(&w, ok, sizeof w);
  const V8f d = w != 0 ? o - intensity * p : V8f{};
  const V4d lo = __builtin_convertvector(V4f{d[0], d[1], d[2], d[3]}, V4d);
  const V4d hi = __builtin_convertvector(V4f{d[4], d[5], d[6], d[7]}, V4d);
  *a += lo * lo, *b += hi * hi;
}

}  // namespace

MATFIT_METRIC_CLONES
double SumSquaredDiff(const float* obs, const float* pred, float intensity, const float* ok,
                      int n) {
  V4d a = {}, b = {}, c = {}, e = {};  // four chains: the adds' latency, not the loads, bound it
  int t = 0;
  for (; t + 16 <= n; t += 16) {
    Accumulate8(obs + t, pred + t, intensity, ok + t, &a, &b);
    Accumulate8(obs + t + 8, pred + t + 8, intensity, ok + t + 8, &c, &e);
  }
  double tail = 0;
  for (; t < n; ++t) {
    const double d = ok[t] != 0 ? double(obs[t] - intensity * pred[t]) : 0.0;
    tail += d * d;
  }
  const V4d s = (a + c) + (b + e);
  return ((s[0] + s[2]) + (s[1] + s[3])) + tail;
}

ReconstructionMetrics ReduceReconstruction(const LightStack& s, const std::vector<int>& images,
                                           const std::vector<double>& run_sum,
                                           const std::vector<int64_t>& run_count, int64_t runs) {
  const int n = int(images.size());
  ReconstructionMetrics m;
  std::map<int, std::pair<double, int64_t>> groups;
  double total = 0;
  for (int i = 0; i < n; ++i) {
    double sum = 0;
    int64_t count = 0;
    for (int64_t r = 0; r < runs; ++r)
      sum += run_sum[size_t(r * n + i)], count += run_count[size_t(r * n + i)];
    total += sum;
    m.samples += count;
    auto& g = groups[int(std::lround(s.lights()[size_t(images[size_t(i)])].theta_deg / 15.0)) * 15];
    g.first += sum, g.second += count;
  }
  const double mse = m.samples ? total / m.samples : 0;
  m.deviation_percent = 100 * mse;
  m.rmse = std::sqrt(mse);
  m.psnr_db = mse > 0 ? 10 * std::log10(1.0 / mse) : INFINITY;
  for (auto& [t, g] : groups)
    m.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return m;
}

ReconstructionMetrics Reconstruction(const LightStack& s, const MaterialMaps& maps,
                                     const std::vector<uint8_t>& status,
                                     const ProgressFn& progress) {
  std::vector<int> all(size_t(s.num_images()));
  for (int i = 0; i < s.num_images(); ++i) all[size_t(i)] = i;
  return Reconstruction(s, all, maps, status, progress);
}

ReconstructionMetrics Reconstruction(const LightStack& s, const std::vector<int>& images,
                                     const MaterialMaps& maps, const std::vector<uint8_t>& status,
                                     const ProgressFn& progress) {
  const int n = int(images.size()), C = s.channels();
  const int64_t T = s.plane_size(), runs = Runs(T);
  std::vector<Vec3f> dirs;
  for (int i : images) dirs.emplace_back(s.lights()[size_t(i)].direction);
  const BatchEvaluator eval(maps, dirs, Vec3f(s.view_direction));
  // Per run and light: Σ d² and the sample count, reduced below in run order.
  std::vector<double> run_sum(size_t(runs * n), 0.0);
  std::vector<int64_t> run_count(size_t(runs * n), 0);
  std::atomic<int64_t> done{0};
  std::mutex progress_mutex;
  ParallelFor(
      0, runs,
      [&](int64_t r0, int64_t r1) {
        std::vector<float> pred(size_t(3) * kEvalRun), scratch(kEvalRun);
        float ok[kEvalRun];
        for (int64_t r = r0; r < r1; ++r) {
          const int64_t p0 = r * kEvalRun;
          const int len = int(std::min<int64_t>(kEvalRun, T - p0));
          int ok_count = 0;
          for (int t = 0; t < len; ++t) {
            const bool use = status.empty() || status[size_t(p0 + t)] == 0;
            ok[t] = use ? 1.0f : 0.0f, ok_count += use;
          }
          if (ok_count == 0) continue;
          for (int i = 0; i < n; ++i) {
            eval.Evaluate(i, p0, len, C, pred.data());
            double acc = 0;
            for (int c = 0; c < C; ++c)
              acc += SumSquaredDiff(
                  s.Texels(images[size_t(i)], c, p0, len, scratch.data()),
                  pred.data() + size_t(c) * len,
                  float(s.lights()[size_t(images[size_t(i)])].intensity[C == 1 ? 0 : c]), ok, len);
            run_sum[size_t(r * n + i)] = acc;
            run_count[size_t(r * n + i)] = int64_t(ok_count) * C;
          }
        }
        const int64_t d = done += r1 - r0;
        if (progress) {
          std::lock_guard<std::mutex> lock(progress_mutex);
          progress(d, runs);
        }
      },
      4);
  return ReduceReconstruction(s, images, run_sum, run_count, runs);
}

std::vector<float> RelightingError(const MaterialMaps& f, const MaterialMaps& t,
                                   const std::vector<Vec3>& lights, const Vec3& view) {
  const int64_t T = int64_t(t.width) * t.height;
  std::vector<float> err(size_t(T), NAN);
  std::vector<Vec3f> dirs(lights.begin(), lights.end());
  const BatchEvaluator fe(f, dirs, Vec3f(view)), te(t, dirs, Vec3f(view));
  ParallelFor(0, Runs(T), [&](int64_t r0, int64_t r1) {
    std::vector<float> a(size_t(3) * kEvalRun), b(size_t(3) * kEvalRun);
    std::vector<double> acc(kEvalRun);
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kEvalRun;
      const int n = int(std::min<int64_t>(kEvalRun, T - p0));
      std::fill_n(acc.begin(), n, 0.0);
      for (int i = 0; i < int(dirs.size()); ++i) {
        fe.Evaluate(i, p0, n, 3, a.data());
        te.Evaluate(i, p0, n, 3, b.data());
        for (int c = 0; c < 3; ++c)
          for (int k = 0; k < n; ++k) {
            const double d = double(a[size_t(c * n + k)]) - double(b[size_t(c * n + k)]);
            acc[size_t(k)] += d * d;
          }
      }
      const double norm = 3.0 * std::max<size_t>(1, lights.size());
      for (int k = 0; k < n; ++k)
        if (t.mask.empty() || t.mask.data()[size_t(p0 + k)] >= 0.5f)
          err[size_t(p0 + k)] = float(std::sqrt(acc[size_t(k)] / norm));
    }
  });
  return err;
}

double ShadingCostNs(const MaterialMaps& maps) {
  const int64_t T = int64_t(maps.width) * maps.height;
  if (T == 0) return 0;
  const std::vector<Vec3f> lights = {Vec3f(0, 0, 1), Normalize(Vec3f(0.5f, 0.2f, 0.8f)),
                                     Normalize(Vec3f(-0.3f, 0.6f, 0.7f)),
                                     Normalize(Vec3f(0.7f, -0.6f, 0.4f))};
  double runs[3];
  volatile float sink = 0;
  std::vector<float> out(size_t(3) * kEvalRun);
  for (double& run : runs) {
    const auto t0 = std::chrono::steady_clock::now();
    const BatchEvaluator eval(maps, lights, Vec3f(0, 0, 1));
    float acc = 0;
    for (int i = 0; i < eval.lights(); ++i)
      for (int64_t p0 = 0; p0 < T; p0 += kEvalRun) {
        const int n = int(std::min<int64_t>(kEvalRun, T - p0));
        eval.Evaluate(i, p0, n, 3, out.data());
        acc += out[0] + out[size_t(3 * n - 1)];
      }
    sink = sink + acc;
    run = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e9 /
          (4.0 * double(T));
  }
  std::sort(runs, runs + 3);
  return runs[1];
}

TruthMetrics CompareToTruth(const MaterialMaps& f, const MaterialMaps& t,
                            const std::vector<uint8_t>& status) {
  TruthMetrics m;
  const ModelDescriptor& model = Model(f.model);
  m.has_normal = model.has_truth_normal();
  m.has_albedo = m.has_normal && model.has_truth_albedo();
  std::vector<double> angles;
  double a2 = 0;
  int64_t ac = 0;
  for (int64_t p = 0; p < int64_t(t.width) * t.height; ++p) {
    if (!status.empty() && status[p] != 0) continue;
    if (!t.mask.empty() && t.mask.data()[p] < 0.5f) continue;
    const Vec3 nf(f.normal.Plane(0)[p], f.normal.Plane(1)[p], f.normal.Plane(2)[p]);
    const Vec3 nt(t.normal.Plane(0)[p], t.normal.Plane(1)[p], t.normal.Plane(2)[p]);
    angles.push_back(AngleBetweenDeg(nf, nt));
    for (int c = 0; c < 3; ++c) {
      const double d = f.albedo.Plane(c)[p] - t.albedo.Plane(c)[p];
      a2 += d * d, ++ac;
    }
  }
  m.texels = int64_t(angles.size());
  if (angles.empty()) return m;
  double sum = 0;
  for (double a : angles) sum += a;
  m.normal_mae_deg = sum / angles.size();
  const size_t k = std::min(angles.size() - 1, size_t(std::ceil(0.95 * angles.size())) - 1);
  std::nth_element(angles.begin(), angles.begin() + k, angles.end());
  m.normal_p95_deg = angles[k];
  m.albedo_rmse = std::sqrt(a2 / ac);
  auto median_error = [&](const Image& fit_plane, const Image& true_plane, bool relative) {
    std::vector<double> e;
    for (int64_t p = 0; p < int64_t(t.width) * t.height; ++p) {
      if (!status.empty() && status[p] != 0) continue;
      if (!t.mask.empty() && t.mask.data()[p] < 0.5f) continue;
      const double a = fit_plane.data()[p], b = true_plane.data()[p];
      e.push_back(relative ? std::abs(a / b - 1) : std::abs(a - b));
    }
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    return e.empty() ? 0.0 : e[e.size() / 2];
  };
  const bool same_size = [&](const Image& a, const Image& b) {
    return !a.empty() && a.data().size() == b.data().size();
  }(f.exponent, t.exponent);
  if (f.model == t.model) {
    if (same_size)
      m.parameter_errors["exponent_median_relative_error"] =
          median_error(f.exponent, t.exponent, true);
    if (!f.roughness.empty() && f.roughness.data().size() == t.roughness.data().size())
      m.parameter_errors["roughness_median_relative_error"] =
          median_error(f.roughness, t.roughness, true);
    if (!f.specular.empty() && f.specular.data().size() == t.specular.data().size())
      m.parameter_errors["specular_median_absolute_error"] =
          median_error(f.specular, t.specular, false);
  }
  return m;
}

}  // namespace matfit::fit
