#include "fit/confidence.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/parallel.h"
#include "core/shading/evaluate.h"
#include "fit/fit_common.h"
#include "fit/fit_types.h"

namespace matfit::fit {

bool ConfidenceOptions::Check(std::string* why) const {
  if (!(kappa > 0) || !std::isfinite(kappa)) {
    *why = "confidence kappa must be a positive number, got " + std::to_string(kappa);
    return false;
  }
  if (!(max_condition > 1)) {
    *why = "confidence max_condition must be > 1, got " + std::to_string(max_condition);
    return false;
  }
  return true;
}

double MeanDomeLeverage(const std::vector<LightSample>& lights, double max_condition, int count) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const auto& l : lights) {
    const Eigen::Vector3d d(l.direction.x, l.direction.y, l.direction.z);
    if (d.allFinite()) M += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(M);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (!(ev(0) > 0) || ev(2) / ev(0) > max_condition) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix3d Minv = M.inverse();
  // Fibonacci spiral, equal area in cos θ over [cos 75°, 1].
  const double zmin = std::cos(75.0 * M_PI / 180.0), golden = M_PI * (3.0 - std::sqrt(5.0));
  double g = 0;
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (k + 0.5) / count * (1.0 - zmin);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = k * golden;
    const Eigen::Vector3d d(r * std::cos(phi), r * std::sin(phi), z);
    g += d.dot(Minv * d);
  }
  return g / count;
}

Confidence ComputeConfidence(const LightStack& s, const MaterialMaps& maps, int parameters,
                             std::vector<uint8_t>* status, const ConfidenceOptions& o) {
  const int64_t T = s.plane_size();
  const int n = s.num_images(), C = s.channels();
  const double P = std::max(1, parameters);
  const double inf = std::numeric_limits<double>::infinity();
  Confidence out;
  out.bound.assign(size_t(T), float(inf));
  if (status && status->empty()) status->assign(size_t(T), kTexelOk);
  auto ok = [&](int64_t p) { return !status || (*status)[p] == kTexelOk; };

  const double g = MeanDomeLeverage(s.lights(), o.max_condition);
  out.extrapolation = std::isfinite(g) ? std::max(1.0, n * g / 3.0) : inf;

  // Pass 1: per-texel residual sums (Σ r², n_x).
  std::vector<double> rss(size_t(T), 0.0);
  std::vector<int> samples(size_t(T), 0);
  const Vec3f v(s.view_direction);
  std::vector<float> inv = InverseIntensities(s);
  ParallelFor(0, s.height(), [&](int64_t y0, int64_t y1) {
    for (int64_t p = y0 * s.width(); p < y1 * s.width(); ++p) {
      if (!ok(p)) continue;
      double acc = 0;
      int k = 0;
      for (int i = 0; i < n; ++i) {
        const Vec3f l(s.lights()[i].direction);
        for (int c = 0; c < C; ++c) {
          const float raw = s.Plane(i, c)[p];
          if (!std::isfinite(raw) || raw >= kClipLevel) continue;
          const double r = double(raw) * inv[size_t(i) * C + c] - EvaluateTexel(maps, p, c, l, v);
          if (!std::isfinite(r)) continue;
          acc += r * r;
          ++k;
        }
      }
      rss[p] = acc, samples[p] = k;
    }
  });
  // Pooled noise over texels with residual degrees of freedom.
  double pooled_rss = 0, pooled_dof = 0;
  for (int64_t p = 0; p < T; ++p)
    if (ok(p) && samples[p] > P) pooled_rss += rss[p], pooled_dof += samples[p] - P;
  const double sigma2 = pooled_dof > 0 ? pooled_rss / pooled_dof : inf;
  out.pooled_sigma = std::sqrt(sigma2);
  for (int64_t p = 0; p < T; ++p) {
    if (!ok(p)) continue;
    const double dof = samples[p] - P;
    if (dof < 1 || !std::isfinite(out.extrapolation) || !std::isfinite(sigma2)) {
      if (status) (*status)[p] = kTexelUnverifiable;
      ++out.unverifiable;
      continue;
    }
    const double s2 = std::max(rss[p] / dof, sigma2);
    out.bound[p] = float(o.kappa * std::sqrt(s2 * out.extrapolation * (1.0 + P / samples[p])));
  }
  return out;
}

}  // namespace matfit::fit
