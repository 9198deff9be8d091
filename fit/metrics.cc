#include "fit/metrics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

#include "core/parallel.h"
#include "core/shading/evaluate.h"

namespace matfit::fit {

ReconstructionMetrics Reconstruction(const LightStack& s, const MaterialMaps& maps,
                                     const std::vector<uint8_t>& status,
                                     const ProgressFn& /*progress: not reported yet*/) {
  const int n = s.num_images(), C = s.channels();
  const Vec3f v(s.view_direction);
  std::vector<double> sum(n, 0.0);
  std::vector<int64_t> count(n, 0);
  ParallelFor(0, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const Vec3f l(s.lights()[i].direction);
      double acc = 0;
      int64_t k = 0;
      for (int64_t p = 0; p < s.plane_size(); ++p) {
        if (!status.empty() && status[p] != 0) continue;
        for (int c = 0; c < C; ++c) {
          const double pred =
              s.lights()[i].intensity[C == 1 ? 0 : c] * EvaluateTexel(maps, p, c, l, v);
          const double d = s.Plane(int(i), c)[p] - pred;
          acc += d * d;
          ++k;
        }
      }
      sum[i] = acc, count[i] = k;
    }
  });
  ReconstructionMetrics m;
  std::map<int, std::pair<double, int64_t>> groups;
  double total = 0;
  for (int i = 0; i < n; ++i) {
    total += sum[i];
    m.samples += count[i];
    auto& g = groups[int(std::lround(s.lights()[i].theta_deg / 15.0)) * 15];
    g.first += sum[i], g.second += count[i];
  }
  const double mse = m.samples ? total / m.samples : 0;
  m.deviation_percent = 100 * mse;
  m.rmse = std::sqrt(mse);
  m.psnr_db = mse > 0 ? 10 * std::log10(1.0 / mse) : INFINITY;
  for (auto& [t, g] : groups)
    m.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return m;
}

std::vector<float> RelightingError(const MaterialMaps& f, const MaterialMaps& t,
                                   const std::vector<Vec3>& lights, const Vec3& view) {
  const int64_t T = int64_t(t.width) * t.height;
  std::vector<float> err(size_t(T), NAN);
  const Vec3f v(view);
  ParallelFor(0, t.height, [&](int64_t y0, int64_t y1) {
    for (int64_t p = y0 * t.width; p < y1 * t.width; ++p) {
      if (!t.mask.empty() && t.mask.data()[p] < 0.5f) continue;
      double acc = 0;
      for (const Vec3& l : lights)
        for (int c = 0; c < 3; ++c) {
          const double d =
              EvaluateTexel(f, p, c, Vec3f(l), v) - EvaluateTexel(t, p, c, Vec3f(l), v);
          acc += d * d;
        }
      err[p] = float(std::sqrt(acc / (3.0 * std::max<size_t>(1, lights.size()))));
    }
  });
  return err;
}

double ShadingCostNs(const MaterialMaps& maps) {
  const int64_t T = int64_t(maps.width) * maps.height;
  if (T == 0) return 0;
  const Vec3f lights[4] = {Vec3f(0, 0, 1), Normalize(Vec3f(0.5f, 0.2f, 0.8f)),
                           Normalize(Vec3f(-0.3f, 0.6f, 0.7f)),
                           Normalize(Vec3f(0.7f, -0.6f, 0.4f))};
  const Vec3f v(0, 0, 1);
  double runs[3];
  volatile float sink = 0;
  for (double& run : runs) {
    const auto t0 = std::chrono::steady_clock::now();
    float acc = 0;
    for (const Vec3f& l : lights)
      for (int64_t p = 0; p < T; ++p)
        for (int c = 0; c < 3; ++c) acc += EvaluateTexel(maps, p, c, l, v);
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
  const ShadingModel fm = f.model;
  const bool relighting_basis = fm == ShadingModel::kPtm || fm == ShadingModel::kHsh;
  m.has_normal = fm != ShadingModel::kMean && !relighting_basis;
  m.has_albedo = m.has_normal && fm != ShadingModel::kHeinrich;
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
