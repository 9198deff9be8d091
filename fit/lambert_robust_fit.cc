// `lambert-robust` (METHODS.md §3): photometric stereo that rejects shadowed and highlight
// samples per texel.
//   1. Rank trimming: fit luminance on the samples ranked between the `trim_dark` and
//      `1 − trim_bright` fractions (cast/attached shadows are dark, highlights bright).
//   2. Reweighting: predicted ŷ_i = max(0, g·l_i), residual r_i = y_i − ŷ_i, robust scale
//      σ = 1.4826 · median |r| over the inliers; inliers are lit (n·l_i > 0.05) with
//      |r_i| ≤ 3σ (+ a noise floor); refit on the inliers, up to 4 rounds.
//   3. The texel is kept only with ≥ 3 inliers whose light directions are well conditioned
//      (smallest/largest eigenvalue of Σ l lᵀ ≥ 1e-3); otherwise it is flagged, not guessed.
// Albedo per channel by 1-D least squares over the final inliers.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/select_kth.h"

namespace matfit::fit {
namespace {

constexpr double kTrimDark = 0.2, kTrimBright = 0.1;
constexpr int kRounds = 4;

struct RankKey {
  double y;
  int i;
};
// Branch-free: (y, i) in lexicographic order.
constexpr auto ByValueThenIndex = [](const RankKey& a, const RankKey& b) {
  return (a.y < b.y) | ((a.y == b.y) & (a.i < b.i));
};

// Least squares g over the samples with keep[i] set; false when fewer than 3 or singular
// (smallest eigenvalue of Σ l lᵀ ≤ 1e-12). The sums run branch-free (keep as a 0/1 factor):
// which samples are kept is data-dependent and would mispredict.
bool SolveSubset(const std::vector<Vec3>& l, const double* y, const std::vector<char>& keep,
                 Vec3* g, double* conditioning) {
  double m00 = 0, m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0, b0 = 0, b1 = 0, b2 = 0;
  int count = 0;
  for (size_t i = 0; i < l.size(); ++i) {
    const double k = keep[i] ? 1.0 : 0.0, kx = k * l[i].x, ky = k * l[i].y, kz = k * l[i].z;
    m00 += kx * l[i].x, m01 += kx * l[i].y, m02 += kx * l[i].z;
    m11 += ky * l[i].y, m12 += ky * l[i].z, m22 += kz * l[i].z;
    b0 += kx * y[i], b1 += ky * y[i], b2 += kz * y[i];
    count += keep[i] != 0;
  }
  if (count < 3) return false;
  Eigen::Matrix3d m;
  m << m00, m01, m02, m01, m11, m12, m02, m12, m22;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(m, Eigen::EigenvaluesOnly);
  const auto ev = eig.eigenvalues();  // ascending
  *conditioning = ev[2] > 0 ? ev[0] / ev[2] : 0;
  if (!(ev[0] > 1e-12)) return false;
  const Eigen::Vector3d x = m.ldlt().solve(Eigen::Vector3d(b0, b1, b2));
  *g = {x.x(), x.y(), x.z()};
  return true;
}

}  // namespace

StatusOr<FitResult> FitLambertRobust(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < 3)
    return InvalidArgument(
        "lambert-robust: only " + std::to_string(n) +
        " light(s); at least 3 non-coplanar lights are needed (more for rejection)");
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, "lambert", "lambert-robust", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/false, &r);  // clipped samples are dropped per sample
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<Vec3> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
  const bool may_clip = StackMayBeClipped(s);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    // The row's samples (linear, [c][i][k]) and luminance ([i][k]) for the texels' loops.
    std::vector<float> vals(size_t(C) * n * t.width);
    std::vector<double> lum(size_t(n) * t.width), y(n), absr(n);
    std::vector<RankKey> keys(n);
    std::vector<char> keep(n), next(n), clipped(n);
    for (int row = t.y0; row < t.y0 + t.height; ++row) {
      const int64_t base = int64_t(row) * W + t.x0;
      // Gather luminance image by image (contiguous rows).
      for (int i = 0; i < n; ++i) {
        double* dst = lum.data() + size_t(i) * t.width;
        std::fill(dst, dst + t.width, 0.0);
        for (int c = 0; c < C; ++c) {
          const float w = (C == 1 ? 1.0f : kLuma[c]) * inv[i * C + c];
          float* v = vals.data() + (size_t(c) * n + i) * t.width;
          const float* src = s.Row(i, c, row, t.x0, t.width, v);
          if (src != v) std::copy_n(src, t.width, v);
          for (int k = 0; k < t.width; ++k) dst[k] += w * v[k];
        }
      }
      for (int k = 0; k < t.width; ++k) {
        const int64_t p = base + k;
        if (r.status[p] != kTexelOk) continue;
        auto sample = [&](int i, int c) { return vals[(size_t(c) * n + i) * t.width + k]; };
        // Clipped samples (at the file's maximum code) and non-finite ones (NaN/Inf in any
        // channel: dead pixels, decode holes) are never used; they rank as dark.
        std::fill(clipped.begin(), clipped.end(), 0);
        if (may_clip)
          for (int i = 0; i < n; ++i)
            for (int c = 0; c < C; ++c) clipped[i] |= sample(i, c) >= kClipLevel;
        int finite = 0;
        for (int i = 0; i < n; ++i) {
          y[i] = lum[size_t(i) * t.width + k];
          if (std::isfinite(y[i])) {
            ++finite;
          } else {
            y[i] = 0, clipped[i] = 1;
          }
        }
        if (finite < 3) {
          r.status[p] = kTexelNonFinite;
          continue;
        }
        // 1. Rank trimming (keep at least 3 of the middle ranks): the samples ranked [lo, hi)
        // are those between the rank-lo and rank-hi keys (two selections, no sort). Ties
        // (shadow zeros, 8-bit codes) break by index, so the kept set is deterministic.
        int lo = int(std::floor(kTrimDark * n)), hi = int(std::ceil((1 - kTrimBright) * n));
        if (hi - lo < 3) lo = std::max(0, std::min(lo, n - 3)), hi = std::min(n, lo + 3);
        for (int i = 0; i < n; ++i) keys[i] = {y[i], i};
        const RankKey first = SelectKth(keys.data(), n, lo, ByValueThenIndex);
        const RankKey end = hi < n ? SelectKth(keys.data(), n, hi, ByValueThenIndex)
                                   : RankKey{0, n};  // past every sample
        for (int i = 0; i < n; ++i) {
          const RankKey key{y[i], i};
          keep[i] = !clipped[i] && !ByValueThenIndex(key, first) &&
                    (hi == n || ByValueThenIndex(key, end));
        }
        Vec3 g;
        double cond = 0;
        bool solved = SolveSubset(dirs, y.data(), keep, &g, &cond);
        // 2. Reweighting rounds.
        for (int round = 0; solved && round < kRounds; ++round) {
          const Vec3 nn = Normalize(g);
          int m = 0;
          for (int i = 0; i < n; ++i)
            if (keep[i]) absr[m++] = std::abs(y[i] - std::max(0.0, Dot(g, dirs[i])));
          const double sigma = 1.4826 * SelectKth(absr.data(), m, m / 2) + 1e-3 * Length(g) + 1e-6;
          for (int i = 0; i < n; ++i) {
            const double pred = std::max(0.0, Dot(g, dirs[i]));
            next[i] = !clipped[i] && Dot(nn, dirs[i]) > 0.05 && std::abs(y[i] - pred) <= 3 * sigma;
          }
          if (next == keep) break;
          Vec3 g2;
          double c2 = 0;
          if (!SolveSubset(dirs, y.data(), next, &g2, &c2)) break;  // keep the last good subset
          keep.swap(next), g = g2, cond = c2;
        }
        const int inliers = int(std::count(keep.begin(), keep.end(), 1));
        if (!solved || inliers < 3) {
          r.status[p] = kTexelTooFewLights;
          continue;
        }
        if (cond < 1e-3) {
          r.status[p] = kTexelIllConditioned;
          continue;
        }
        const double len = Length(g);
        if (!(len > 1e-6)) {
          r.status[p] = kTexelNoSignal;
          continue;
        }
        const Vec3 nn = g / len;
        double num[3] = {0, 0, 0}, den = 0;
        for (int i = 0; i < n; ++i) {
          if (!keep[i]) continue;
          const double si = std::max(0.0, Dot(nn, dirs[i]));
          den += si * si;
          for (int c = 0; c < C; ++c) num[c] += sample(i, c) * inv[i * C + c] * si;
        }
        for (int c = 0; c < 3; ++c) {
          r.maps.normal.Plane(c)[p] = float(nn[c]);
          r.maps.albedo.Plane(c)[p] = float(den > 0 ? num[C == 1 ? 0 : c] / den : 0);
        }
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
