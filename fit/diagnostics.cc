#include "fit/diagnostics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/parallel.h"
#include "core/warnings.h"
#include "fit/fit_common.h"

namespace matfit::fit {
namespace {

struct TexelSamples {
  std::vector<Eigen::Vector3d> l;
  std::vector<double> p;
  std::vector<double> log_p;          // ln p, so that p^γ = exp(γ ln p) per trial γ
  Eigen::LDLT<Eigen::Matrix3d> ldlt;  // of A = Σ l lᵀ, which does not depend on γ
};

// Pooled relative residual Σ_x Σ (y − l·g_x)² / Σ_x Σ (y − ȳ_x)² of per-texel least squares on
// y = p^γ: the share of each texel's variation over lights that n·l does not explain (the
// variance, not the energy, so γ → 0, where y flattens to a constant, is not favoured).
// Parallel over fixed chunks of texels, summed in chunk order (the same for any thread count).
double LambertResidual(const std::vector<TexelSamples>& texels, double gamma) {
  constexpr int64_t kChunk = 64;
  const int64_t chunks = (int64_t(texels.size()) + kChunk - 1) / kChunk;
  std::vector<double> nums(size_t(chunks), 0.0), dens(size_t(chunks), 0.0);
  ParallelFor(0, chunks, [&](int64_t c0, int64_t c1) {
    std::vector<double> y;
    for (int64_t c = c0; c < c1; ++c) {
      double num = 0, den = 0;
      for (int64_t x = c * kChunk; x < std::min<int64_t>((c + 1) * kChunk, texels.size()); ++x) {
        const TexelSamples& t = texels[size_t(x)];
        y.resize(t.p.size());
        Eigen::Vector3d b = Eigen::Vector3d::Zero();
        double mean = 0;
        for (size_t i = 0; i < t.p.size(); ++i) {
          y[i] = gamma == 1.0 ? t.p[i] : std::exp(gamma * t.log_p[i]);
          mean += y[i] / double(y.size());
          b += y[i] * t.l[i];
        }
        const Eigen::Vector3d g = t.ldlt.solve(b);
        for (size_t i = 0; i < y.size(); ++i) {
          const double r = y[i] - t.l[i].dot(g);
          num += r * r, den += (y[i] - mean) * (y[i] - mean);
        }
      }
      nums[size_t(c)] = num, dens[size_t(c)] = den;
    }
  });
  double num = 0, den = 0;
  for (int64_t c = 0; c < chunks; ++c) num += nums[size_t(c)], den += dens[size_t(c)];
  return den > 0 ? num / den : 0;
}

}  // namespace

StackDiagnostics DiagnoseStack(const LightStack& s, int max_texels) {
  StackDiagnostics d;
  const int n = s.num_images(), C = s.channels();
  if (n < 6) return d;
  const int64_t T = s.plane_size();
  // A regular 2-D grid of about max_texels texels (a 1-D stride would pick a few columns).
  const int step = std::max(1, int(std::sqrt(double(T) / std::max(1, max_texels))));
  const bool clip = StackMayBeClipped(s);
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<TexelSamples> texels;
  std::vector<std::pair<double, int>> v;
  for (int64_t p0 = 0; p0 < T; ++p0) {
    const int x = int(p0 % s.width()), yy = int(p0 / s.width());
    if (x % step != step / 2 || yy % step != step / 2) continue;
    const int64_t p = p0;
    if (s.has_mask() && s.mask.data()[p] < 0.5f) continue;
    v.clear();
    for (int i = 0; i < n; ++i) {
      double y = 0;
      bool good = s.lights()[i].direction.z > 0;
      for (int c = 0; c < C; ++c) {
        const float raw = s.Sample(i, c, p);
        good = good && std::isfinite(raw) && !(clip && raw >= kClipLevel);
        y += (C == 3 ? kLuma[c] : 1.0f) * raw * inv[size_t(i) * C + c];
      }
      if (good && y > 1e-3) v.push_back({y, i});
    }
    if (v.size() < 8) continue;
    std::sort(v.begin(), v.end());
    const size_t lo = v.size() / 10, hi = v.size() - v.size() / 4;
    if (hi - lo < 6) continue;
    TexelSamples t;
    const double scale = 1.0 / v[hi - 1].first;  // γ acts on relative values
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    for (size_t k = lo; k < hi; ++k) {
      const auto& dir = s.lights()[v[k].second].direction;
      t.l.emplace_back(dir.x, dir.y, dir.z);
      t.p.push_back(v[k].first * scale);
      t.log_p.push_back(std::log(t.p.back()));
      A += t.l.back() * t.l.back().transpose();
    }
    t.ldlt.compute(A);
    texels.push_back(std::move(t));
  }
  d.texels_used = int(texels.size());
  if (texels.size() < 16) return d;
  d.residual_linear = LambertResidual(texels, 1.0);
  // Golden-section search on log γ over [0.3, 3.3] after a coarse scan.
  double best = 1.0, best_r = d.residual_linear;
  for (int k = 0; k <= 24; ++k) {
    const double g = 0.3 * std::pow(11.0, k / 24.0);
    const double r = LambertResidual(texels, g);
    if (r < best_r) best_r = r, best = g;
  }
  double a = std::log(best) - std::log(11.0) / 24, b = std::log(best) + std::log(11.0) / 24;
  const double phi = (std::sqrt(5.0) - 1) / 2;
  // One new residual per step: the kept interior point is the next step's other one.
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
  double r1 = LambertResidual(texels, std::exp(x1)), r2 = LambertResidual(texels, std::exp(x2));
  for (int it = 0; it < 20; ++it) {
    if (r1 < r2) {
      b = x2, x2 = x1, r2 = r1;
      x1 = b - phi * (b - a), r1 = LambertResidual(texels, std::exp(x1));
    } else {
      a = x1, x1 = x2, r1 = r2;
      x2 = a + phi * (b - a), r2 = LambertResidual(texels, std::exp(x2));
    }
  }
  const double g = std::exp((a + b) / 2), r = LambertResidual(texels, g);
  if (r < best_r) best = g, best_r = r;
  d.encoding_exponent = best;
  d.residual_best = best_r;
  // Only an interior minimum is evidence (at the ends of [0.3, 3.3] the search is inconclusive).
  d.looks_gamma_encoded = best >= 1.6 && best <= 3.0 && best_r < 0.5 * d.residual_linear;
  if (d.looks_gamma_encoded) {
    char msg[320];
    std::snprintf(
        msg, sizeof msg,
        "the images look gamma-encoded but were read as linear: values grow like "
        "(n·l)^(1/%.2f), not n·l (Lambertian residual %.2g → %.2g); re-read them as "
        "sRGB (--color-space srgb) or linearise them; every texel is marked 'suspect data'",
        best, d.residual_linear, best_r);
    d.warnings.push_back(Warning(WarningCode::kGammaEncoded, msg));
  }
  return d;
}

}  // namespace matfit::fit
