#include "fit/confidence.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define MATFIT_CONFIDENCE_CLONES __attribute__((target_clones("arch=haswell", "default")))
#else
#define MATFIT_CONFIDENCE_CLONES
#endif
#include "fit/fit_common.h"
#include "fit/fit_types.h"

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

namespace {

// One light and channel of a run: q = raw / I, r = q − pred for the samples that are finite and
// below the clip level; Σ r², Σ |q|, the sample count, and whether the light was used.
MATFIT_CONFIDENCE_CLONES
void ResidualSums(const float* __restrict raw, const float* __restrict pred, float inv,
                  float clip_level, int n, double* __restrict acc, double* __restrict sum,
                  int* __restrict k, int* __restrict used) {
  for (int t = 0; t < n; ++t) {
    const double q = double(raw[t]) * inv;
    const double r = q - double(pred[t]);
    const bool valid = std::isfinite(raw[t]) && raw[t] < clip_level && std::isfinite(r);
    acc[t] += valid ? r * r : 0.0;
    sum[t] += valid ? std::abs(q) : 0.0;
    k[t] += valid;
    used[t] |= valid;
  }
}

}  // namespace

Confidence ComputeConfidence(const LightStack& s, const MaterialMaps& maps, ModelSize size,
                             std::vector<uint8_t>* status, const ConfidenceOptions& o,
                             const ProgressFn& progress) {
  const int64_t T = s.plane_size();
  const int n = s.num_images(), C = s.channels();
  // Grey stacks fit the per-channel parameters once instead of three times.
  const double P = std::max(1, size.parameters - (3 - std::min(C, 3)) * size.per_channel);
  const bool clip = StackMayBeClipped(s);
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

  // Pass 1: per-texel residual sums (Σ r², n_x), usable lights m_x and mean level μ_x, batched:
  // runs of kEvalRun texels, each light's constants once, the texel sums in SoA arrays.
  std::vector<double> rss(size_t(T), 0.0), level(size_t(T), 0.0);
  std::vector<int> samples(size_t(T), 0), used_lights(size_t(T), 0);
  std::vector<Vec3f> dirs;
  for (const auto& l : s.lights()) dirs.emplace_back(l.direction);
  const BatchEvaluator eval(maps, dirs, Vec3f(s.view_direction));
  const std::vector<float> inv = InverseIntensities(s);
  const float clip_level = clip ? kClipLevel : std::numeric_limits<float>::infinity();
  const int64_t runs = (T + kEvalRun - 1) / kEvalRun;
  std::atomic<int64_t> done{0};
  std::mutex progress_mutex;
  ParallelFor(
      0, runs,
      [&](int64_t r0, int64_t r1) {
        std::vector<float> pred(size_t(3) * kEvalRun), scratch(kEvalRun);
        std::vector<double> acc(kEvalRun), sum(kEvalRun);
        std::vector<int> k(kEvalRun), m(kEvalRun), used(kEvalRun);
        for (int64_t r = r0; r < r1; ++r) {
          const int64_t p0 = r * kEvalRun;
          const int len = int(std::min<int64_t>(kEvalRun, T - p0));
          bool any = false;
          for (int t = 0; t < len && !any; ++t) any = ok(p0 + t);
          if (!any) continue;
          std::fill_n(acc.begin(), len, 0.0), std::fill_n(sum.begin(), len, 0.0);
          std::fill_n(k.begin(), len, 0), std::fill_n(m.begin(), len, 0);
          for (int i = 0; i < n; ++i) {
            eval.Evaluate(i, p0, len, C, pred.data());
            std::fill_n(used.begin(), len, 0);
            for (int c = 0; c < C; ++c)
              ResidualSums(s.Texels(i, c, p0, len, scratch.data()), pred.data() + size_t(c) * len,
                           inv[size_t(i) * C + c], clip_level, len, acc.data(), sum.data(),
                           k.data(), used.data());
            for (int t = 0; t < len; ++t) m[size_t(t)] += used[size_t(t)];
          }
          for (int t = 0; t < len; ++t) {
            const int64_t p = p0 + t;
            if (!ok(p)) continue;
            rss[p] = acc[t], samples[p] = k[t], used_lights[p] = m[t];
            level[p] = k[t] ? sum[t] / k[t] : 0;
          }
        }
        const int64_t d = done += r1 - r0;
        if (progress) {
          std::lock_guard<std::mutex> lock(progress_mutex);
          progress(d, runs);
        }
      },
      4);
  // Pooled noise over texels with residual degrees of freedom.
  double pooled_rss = 0, pooled_dof = 0;
  for (int64_t p = 0; p < T; ++p)
    if (ok(p) && samples[p] > P) pooled_rss += rss[p], pooled_dof += samples[p] - P;
  const double sigma2 = pooled_dof > 0 ? pooled_rss / pooled_dof : inf;
  out.pooled_sigma = std::sqrt(sigma2);
  for (int64_t p = 0; p < T; ++p) {
    if (!ok(p)) continue;
    const double dof = samples[p] - P;
    if (dof < 1 || used_lights[p] < min_lights || !out.frontal_covered ||
        !std::isfinite(out.extrapolation) || !std::isfinite(sigma2)) {
      if (status) (*status)[p] = kTexelUnverifiable;
      ++out.unverifiable;
      continue;
    }
    const double s2 = std::max(rss[p] / dof, sigma2);
    const double extra = (out.extrapolation - 1) * level[p];
    out.bound[p] = float(std::sqrt(
        o.kappa * o.kappa * s2 * out.extrapolation * (1.0 + P / samples[p]) + extra * extra));
  }
  return out;
}

}  // namespace matfit::fit
