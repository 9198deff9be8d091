#include "fit/metrics.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/stack_band.h"
#include "fit/fit_types.h"
#include "fit/score.h"

namespace matfit::fit {

namespace {

int64_t Runs(int64_t texels) { return (texels + kEvalRun - 1) / kEvalRun; }

}  // namespace

ReconstructionMetrics Reconstruction(const LightStack& s, const MaterialMaps& maps,
                                     const std::vector<uint8_t>& status,
                                     const ProgressFn& progress) {
  return ScoreStack(s, maps, status, progress, {.reconstruction = true, .residuals = false})
      .reconstruction;
}

ReconstructionMetrics Reconstruction(const LightStack& s, const std::vector<int>& images,
                                     const MaterialMaps& maps, const std::vector<uint8_t>& status,
                                     const ProgressFn& progress) {
  return ScoreStack(s, images, maps, status, progress,
                    {.reconstruction = true, .residuals = false, .srgb8 = true})
      .reconstruction;
}

namespace {

// Per texel: sqrt(Σ d² / (lights · channels)) over the differences `add(i, p0, n, scratch, acc)`
// accumulates for light i into acc[k] (texel p0 + k); NaN where keep(p) is false. Runs of
// kEvalRun texels in parallel; `scratch` holds 6 · kEvalRun floats per thread.
template <typename Add, typename Keep>
std::vector<float> PerTexelRms(int64_t T, int lights, int channels, const Add& add,
                               const Keep& keep) {
  std::vector<float> err(size_t(T), NAN);
  ParallelFor(0, Runs(T), [&](int64_t r0, int64_t r1) {
    std::vector<float> scratch(size_t(6) * kEvalRun);
    std::vector<double> acc(kEvalRun);
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kEvalRun;
      const int n = int(std::min<int64_t>(kEvalRun, T - p0));
      std::fill_n(acc.begin(), n, 0.0);
      for (int i = 0; i < lights; ++i) add(i, p0, n, scratch.data(), acc.data());
      const double norm = double(channels) * std::max(1, lights);
      for (int k = 0; k < n; ++k)
        if (keep(p0 + k)) err[size_t(p0 + k)] = float(std::sqrt(acc[size_t(k)] / norm));
    }
  });
  return err;
}

}  // namespace

std::vector<float> RelightingError(const MaterialMaps& f, const MaterialMaps& t,
                                   const std::vector<Vec3>& lights, const Vec3& view,
                                   const Vec3& recorded_limit) {
  std::vector<Vec3f> dirs(lights.begin(), lights.end());
  const BatchEvaluator fe(f, dirs, Vec3f(view)), te(t, dirs, Vec3f(view));
  const bool limited = std::min({recorded_limit.x, recorded_limit.y, recorded_limit.z}) < INFINITY;
  const float limit[3] = {float(recorded_limit.x), float(recorded_limit.y),
                          float(recorded_limit.z)};
  return PerTexelRms(
      int64_t(t.width) * t.height, int(dirs.size()), 3,
      [&](int i, int64_t p0, int n, float* scratch, double* acc) {
        float *a = scratch, *b = scratch + size_t(3) * kEvalRun;
        fe.Evaluate(i, p0, n, 3, a);
        te.Evaluate(i, p0, n, 3, b);
        if (limited)  // channel-major (c · n + k); std::min keeps a NaN first argument
          for (int c = 0; c < 3; ++c)
            for (int k = c * n; k < (c + 1) * n; ++k)
              a[k] = std::min(a[k], limit[c]), b[k] = std::min(b[k], limit[c]);
        for (int c = 0; c < 3; ++c)
          for (int k = 0; k < n; ++k) {
            const double d = double(a[size_t(c * n + k)]) - double(b[size_t(c * n + k)]);
            acc[k] += d * d;
          }
      },
      [&](int64_t p) { return t.mask.empty() || t.mask.data()[size_t(p)] >= 0.5f; });
}

std::vector<float> RelightingError(const MaterialMaps& f, const LightStack& t) {
  std::vector<Vec3f> dirs, views;
  for (int i = 0; i < t.num_images(); ++i)
    dirs.emplace_back(t.lights()[size_t(i)].direction), views.emplace_back(t.ViewOf(i));
  const BatchEvaluator fe(f, dirs, views);
  const int C = t.channels();
  return PerTexelRms(
      t.plane_size(), int(dirs.size()), C,
      [&](int i, int64_t p0, int n, float* scratch, double* acc) {
        float* a = scratch;
        fe.Evaluate(i, p0, n, 3, a);
        for (int c = 0; c < C; ++c) {
          const float* b = t.Texels(i, c, p0, n, scratch + size_t(3) * kEvalRun);
          const double inv = 1.0 / t.lights()[size_t(i)].intensity[C == 1 ? 0 : c];
          for (int k = 0; k < n; ++k) {
            const double d = double(a[size_t(c * n + k)]) - double(b[k]) * inv;
            acc[k] += d * d;
          }
        }
      },
      [&](int64_t p) { return !t.has_mask() || t.mask[size_t(p)] != 0; });
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

void ReconstructionSums::Add(const ReconstructionMetrics& m, int theta_group) {
  const double n = double(m.samples);
  sse_ += m.rmse * m.rmse * n, samples_ += n;
  if (std::isfinite(m.rmse_srgb8))
    sse8_ += m.rmse_srgb8 * m.rmse_srgb8 * n;
  else if (n > 0)
    srgb8_ = false;
  by_theta_[theta_group].first += m.deviation_percent * n;
  by_theta_[theta_group].second += n;
}

ReconstructionMetrics MetricsFromSums(double sse, double samples) {
  ReconstructionMetrics m;
  m.samples = int64_t(samples);
  const double mse = samples > 0 ? sse / samples : 0;
  m.rmse = std::sqrt(mse);
  m.deviation_percent = 100 * mse;
  m.psnr_db = mse > 0 ? 10 * std::log10(1 / mse) : INFINITY;
  return m;
}

ReconstructionMetrics ReconstructionSums::Metrics() const {
  ReconstructionMetrics m = MetricsFromSums(sse_, samples_);
  if (srgb8_ && samples_ > 0) {
    const double mse8 = sse8_ / samples_;
    m.rmse_srgb8 = std::sqrt(mse8);
    m.psnr_srgb8_db = mse8 > 0 ? 10 * std::log10(255.0 * 255.0 / mse8) : INFINITY;
  }
  for (const auto& [tl, sn] : by_theta_)
    if (sn.second > 0) m.deviation_percent_by_theta[tl] = sn.first / sn.second;
  return m;
}

std::vector<uint8_t> CommonTexelStatus(const std::vector<uint8_t>& status) {
  std::vector<uint8_t> out(status.size());
  for (size_t p = 0; p < status.size(); ++p)
    out[p] = status[p] == kTexelMasked ? uint8_t(kTexelMasked) : uint8_t(kTexelOk);
  return out;
}

bool AnyFlagged(const std::vector<uint8_t>& status) {
  for (uint8_t st : status)
    if (st != kTexelOk && st != kTexelMasked) return true;
  return false;
}

bool AnyFlagged(const LightStack& s, const std::vector<uint8_t>& status) {
  int64_t any = AnyFlagged(status);
  SumOverBands(s, &any, 1);
  return any > 0;
}

}  // namespace matfit::fit
