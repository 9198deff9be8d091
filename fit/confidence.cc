#include "fit/confidence.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/stack_band.h"

#include "fit/fit_common.h"
#include "fit/fit_types.h"
#include "fit/score.h"

namespace matfit::fit {

bool ConfidenceOptions::Check(std::string* why) const {
  if (!(kappa > 0) || !std::isfinite(kappa)) {
    *why = "confidence kappa must be a positive number, got " + std::to_string(kappa);
    return false;
  }
  if (!(max_frontal_gap_deg > 0 && max_frontal_gap_deg <= 90)) {
    *why = "confidence max_frontal_gap_deg must be in (0, 90], got " +
           std::to_string(max_frontal_gap_deg);
    return false;
  }
  if (!(max_extrapolation >= 1)) {
    *why = "confidence max_extrapolation must be ≥ 1, got " + std::to_string(max_extrapolation);
    return false;
  }
  if (!(max_condition > 1)) {
    *why = "confidence max_condition must be > 1, got " + std::to_string(max_condition);
    return false;
  }
  return true;
}

std::vector<Vec3> DomeDirections(int count, double max_theta_deg, const Vec3& axis) {
  // Fibonacci spiral, equal area in cos θ over [cos θ_max, 1] about +z, then rotated so +z
  // becomes `axis` (an orthonormal frame t, b, a).
  const Vec3 a = Normalize(axis);
  const Vec3 t = Normalize(std::abs(a.x) < 0.9 ? Cross(Vec3(1, 0, 0), a) : Cross(Vec3(0, 1, 0), a));
  const Vec3 b = Cross(a, t);
  const double zmin = std::cos(max_theta_deg * M_PI / 180.0),
               golden = M_PI * (3.0 - std::sqrt(5.0));
  std::vector<Vec3> d;
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (k + 0.5) / count * (1.0 - zmin);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = k * golden;
    d.push_back(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + a * z);
  }
  return d;
}

Vec3 LightAxis(const std::vector<LightSample>& lights) {
  Vec3 sum;
  for (const auto& l : lights)
    if (l.direction.z > 0 && IsFinite(l.direction)) sum += Normalize(l.direction);
  return Length(sum) > 1e-9 ? Normalize(sum) : Vec3(0, 0, 1);
}

double MeanDomeLeverage(const std::vector<LightSample>& lights, double max_condition,
                        double max_theta_deg, const Vec3& axis, int count) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const auto& l : lights) {
    const Eigen::Vector3d d(l.direction.x, l.direction.y, l.direction.z);
    if (d.allFinite()) M += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(M);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (!(ev(0) > 0) || ev(2) / ev(0) > max_condition) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix3d Minv = M.inverse();
  double g = 0;
  for (const Vec3& v : DomeDirections(count, max_theta_deg, axis)) {
    const Eigen::Vector3d d(v.x, v.y, v.z);
    g += d.dot(Minv * d);
  }
  return g / count;
}

double SupportedThetaDeg(const std::vector<LightSample>& lights, const Vec3& axis) {
  double t = 0;
  for (const auto& l : lights)
    if (l.direction.z > 0 && IsFinite(l.direction))
      t = std::max(t, AngleBetweenDeg(l.direction, axis));
  return std::min(75.0, t + 15.0);
}

Confidence ComputeConfidence(const LightStack& s, const MaterialMaps& maps, ModelSize size,
                             std::vector<uint8_t>* status, const ConfidenceOptions& o,
                             const ProgressFn& progress, const TexelResiduals* residuals) {
  const int64_t T = s.plane_size();
  const int n = s.num_images(), C = s.channels();
  // Grey stacks fit the per-channel parameters once instead of three times.
  const double P = std::max(1, size.parameters - (3 - std::min(C, 3)) * size.per_channel);
  const int min_lights = size.light_parameters + 3;
  const double inf = std::numeric_limits<double>::infinity();
  Confidence out;
  out.bound.assign(size_t(T), float(inf));
  if (status && status->empty()) status->assign(size_t(T), kTexelOk);
  auto ok = [&](int64_t p) { return !status || (*status)[p] == kTexelOk; };

  double nearest = 90;
  for (const auto& l : s.lights())
    if (l.direction.z > 0)
      nearest = std::min(nearest, std::acos(std::min(1.0, l.direction.z)) * 180 / M_PI);
  out.frontal_covered = nearest <= o.max_frontal_gap_deg;
  // θ_s: from min(75°, widest light angle from the axis + 15°) down in 5° steps until the
  // extrapolation factor is at most max_extrapolation; none → the lights cannot predict any
  // cone of directions: unverifiable.
  out.supported_axis = LightAxis(s.lights());
  out.extrapolation = inf;
  for (double t = SupportedThetaDeg(s.lights(), out.supported_axis); t >= 10 - 1e-9; t -= 5) {
    const double g = MeanDomeLeverage(s.lights(), o.max_condition, t, out.supported_axis);
    const double a = std::isfinite(g) ? std::max(1.0, n * g / 3.0) : inf;
    if (!std::isfinite(g)) break;  // singular: no smaller dome helps
    out.supported_theta_deg = t, out.extrapolation = a;
    if (a <= o.max_extrapolation) break;
  }
  if (out.extrapolation > o.max_extrapolation) out.extrapolation = inf;

  // Pass 1 (fit/score.h): per-texel residual sums Σ r², n_x, usable lights m_x, mean level μ_x.
  TexelResiduals own;
  if (!residuals) {
    static const std::vector<uint8_t> kAllOk;  // no status plane: every texel
    own = ScoreStack(s, maps, status ? *status : kAllOk, progress,
                     {.reconstruction = false, .residuals = true})
              .residuals;
    residuals = &own;
  }
  MATFIT_CHECK(residuals->rss.size() == size_t(T) && residuals->clipped_lights.size() == size_t(T),
               "ComputeConfidence: residuals of another stack");
  const std::vector<double>&rss = residuals->rss, &level = residuals->level;
  const std::vector<int>&samples = residuals->samples, &used_lights = residuals->used_lights;
  const std::vector<int>& clipped_lights = residuals->clipped_lights;
  if (StackMayBeClipped(s)) {
    // Per channel, the largest value any light could have recorded, per unit light: the maximum
    // code (1) over the weakest light's intensity, 1 / I. Grey stacks: one channel for all three.
    const std::vector<float> inv = InverseIntensities(s);
    double limit[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        if (const float v = inv[size_t(i) * C + (C == 1 ? 0 : c)]; std::isfinite(v))
          limit[c] = std::max(limit[c], double(v));
    auto or_inf = [&](double v) { return v > 0 ? v : inf; };
    out.recorded_limit = Vec3(or_inf(limit[0]), or_inf(limit[1]), or_inf(limit[2]));
  }
  // Pooled noise over texels with residual degrees of freedom.
  double pooled_rss = 0, pooled_dof = 0;
  for (int64_t p = 0; p < T; ++p)
    if (ok(p) && samples[p] > P) pooled_rss += rss[p], pooled_dof += samples[p] - P;
  double pooled[2] = {pooled_rss, pooled_dof};  // over every band of a distributed stack
  SumOverBands(s, pooled, 2);
  pooled_rss = pooled[0], pooled_dof = pooled[1];
  const double sigma2 = pooled_dof > 0 ? pooled_rss / pooled_dof : inf;
  out.pooled_sigma = std::sqrt(sigma2);
  const Image& ie = maps.interpolation_error;
  const bool interp = ie.width() == s.width() && ie.height() == s.height() && ie.channels() == 1;
  // Per texel, independent: in parallel, the unverifiable texels counted per chunk.
  constexpr int64_t kChunk = 1 << 14;
  const int64_t chunks = (T + kChunk - 1) / kChunk;
  std::vector<int64_t> unverifiable(size_t(chunks), 0), saturated(size_t(chunks), 0);
  ParallelFor(0, chunks, [&](int64_t c0, int64_t c1) {
    for (int64_t p = c0 * kChunk; p < std::min(T, c1 * kChunk); ++p) {
      if (!ok(p)) continue;
      const double dof = samples[p] - P;
      if (dof < 1 || used_lights[p] < min_lights || !out.frontal_covered ||
          !std::isfinite(out.extrapolation) || !std::isfinite(sigma2)) {
        if (status) (*status)[p] = kTexelUnverifiable;
        ++unverifiable[size_t(p / kChunk)];
        continue;
      }
      double s2 = std::max(rss[p] / dof, sigma2);
      if (interp)  // an interpolating model's error between its samples
        s2 = std::max(s2, std::pow(double(maps.interpolation_error.Plane(0)[p]), 2));
      const double extra = (out.extrapolation - 1) * level[p];
      out.bound[p] = float(std::sqrt(
          o.kappa * o.kappa * s2 * out.extrapolation * (1.0 + P / samples[p]) + extra * extra));
      saturated[size_t(p / kChunk)] += clipped_lights[size_t(p)] > 0;
    }
  });
  for (int64_t u : unverifiable) out.unverifiable += u;
  for (int64_t u : saturated) out.saturated += u;
  return out;
}

BoundRatio BoundToActualRatio(const std::vector<float>& bound, const std::vector<float>& actual,
                              const std::vector<uint8_t>& status) {
  std::vector<double> r;
  for (size_t p = 0; p < bound.size() && p < actual.size(); ++p) {
    if (!status.empty() && status[p] != kTexelOk) continue;
    if (!std::isfinite(bound[p]) || !std::isfinite(actual[p]) || actual[p] <= 0) continue;
    r.push_back(double(bound[p]) / double(actual[p]));
  }
  BoundRatio out;
  out.texels = int64_t(r.size());
  if (r.empty()) return out;
  const auto quantile = [&](double q) {
    const size_t k = std::min(r.size() - 1, size_t(q * double(r.size())));
    std::nth_element(r.begin(), r.begin() + k, r.end());
    return r[k];
  };
  out.exceeded_fraction =
      double(std::count_if(r.begin(), r.end(), [](double v) { return v < 1; })) / double(r.size());
  out.median = quantile(0.5);
  out.p90 = quantile(0.9);
  return out;
}

}  // namespace matfit::fit
