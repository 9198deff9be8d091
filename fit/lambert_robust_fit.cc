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
#include <functional>
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

// The key (value, index) of rank r in (value, index) order, given v, the value of rank r in value
// order: the (r − #{y < v})-th sample, in index order, of those equal to v. Selecting plain values
// and resolving ties here is about twice as fast as selecting 16-byte keys.
RankKey KeyOfRank(const double* y, int n, double v, int r) {
  int below = 0;
  for (int i = 0; i < n; ++i) below += y[i] < v ? 1 : 0;
  for (int i = 0, want = r - below; i < n; ++i)
    if (y[i] == v && want-- == 0) return {v, i};
  return {v, n};  // unreachable: v is one of the values
}

// Light directions and their products l lᵀ, one array per component (the sums below read them
// contiguously).
struct LightTable {
  explicit LightTable(const std::vector<Vec3>& d) {
    for (const Vec3& l : d) {
      x.push_back(l.x), y.push_back(l.y), z.push_back(l.z);
      xx.push_back(l.x * l.x), xy.push_back(l.x * l.y), xz.push_back(l.x * l.z);
      yy.push_back(l.y * l.y), yz.push_back(l.y * l.z), zz.push_back(l.z * l.z);
    }
  }
  int size() const { return int(x.size()); }
  std::vector<double> x, y, z, xx, xy, xz, yy, yz, zz;
};

// Least squares g over the samples with keep[i] set: M g = b with M = Σ l lᵀ, b = Σ l y. False
// when fewer than 3 or singular (smallest eigenvalue of M ≤ 1e-12); *m is M. The sums run
// branch-free (a kept sample adds its terms, another adds 0): which samples are kept is
// data-dependent and would mispredict.
bool SolveSubset(const LightTable& L, const double* y, const std::vector<char>& keep, Vec3* g,
                 Eigen::Matrix3d* m) {
  double m00 = 0, m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0, b0 = 0, b1 = 0, b2 = 0;
  int count = 0;
  for (int i = 0; i < L.size(); ++i) {
    const bool k = keep[i] != 0;
    m00 += k ? L.xx[i] : 0.0, m01 += k ? L.xy[i] : 0.0, m02 += k ? L.xz[i] : 0.0;
    m11 += k ? L.yy[i] : 0.0, m12 += k ? L.yz[i] : 0.0, m22 += k ? L.zz[i] : 0.0;
    b0 += k ? L.x[i] * y[i] : 0.0, b1 += k ? L.y[i] * y[i] : 0.0, b2 += k ? L.z[i] * y[i] : 0.0;
    count += k;
  }
  if (count < 3) return false;
  *m << m00, m01, m02, m01, m11, m12, m02, m12, m22;
  // For a positive semi-definite 3×3, λ_min ≥ det / (λ_mid λ_max) ≥ 4 det / tr²: when that bound
  // is far above 1e-12 (its rounding is ~1e-15 tr²) the eigen-decomposition is not needed.
  const double tr = m00 + m11 + m22, det = m->determinant();
  if (!(4 * det >= 1e-6 * tr * tr)) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(*m, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues()[0] > 1e-12)) return false;
  }
  const Eigen::Vector3d x = m->ldlt().solve(Eigen::Vector3d(b0, b1, b2));
  *g = {x.x(), x.y(), x.z()};
  return true;
}

// Smallest / largest eigenvalue of M (0 when M vanishes).
double Conditioning(const Eigen::Matrix3d& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(m, Eigen::EigenvaluesOnly);
  const auto ev = eig.eigenvalues();  // ascending
  return ev[2] > 0 ? ev[0] / ev[2] : 0;
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
  const LightTable L(dirs);
  const bool may_clip = StackMayBeClipped(s);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int tw = t.width;
    // The row's samples (linear, [c][i][k]), luminance ([i][k]) and clipped flags ([i][k]),
    // gathered image by image (contiguous rows); then, for a block of kBlock texels at a time,
    // transposed to one contiguous run per texel (texel k's luminance of image i 4 KiB from
    // image i + 1's would miss the cache on every sample).
    constexpr int kBlock = 8;
    std::vector<float> vals(size_t(C) * n * tw);
    std::vector<double> lum(size_t(n) * tw), ys(size_t(kBlock) * n), d(n), e(n), absr(n);
    std::vector<char> clip(size_t(n) * tw), bad(size_t(kBlock) * n);
    std::vector<double> vals_sel(n);
    std::vector<char> keep(n), next(n);
    Eigen::Matrix3d m, m2;
    for (int row = t.y0; row < t.y0 + t.height; ++row) {
      const int64_t base = int64_t(row) * W + t.x0;
      for (int i = 0; i < n; ++i) {
        double* dst = lum.data() + size_t(i) * tw;
        char* cl = clip.data() + size_t(i) * tw;
        std::fill(dst, dst + tw, 0.0);
        std::fill(cl, cl + tw, char(0));
        for (int c = 0; c < C; ++c) {
          const float w = (C == 1 ? 1.0f : kLuma[c]) * inv[i * C + c];
          float* v = vals.data() + (size_t(c) * n + i) * tw;
          const float* src = s.Row(i, c, row, t.x0, tw, v);
          if (src != v) std::copy_n(src, tw, v);
          for (int k = 0; k < tw; ++k) dst[k] += w * v[k];
          // Clipped samples (at the file's maximum code) are never used.
          if (may_clip)
            for (int k = 0; k < tw; ++k) cl[k] |= char(v[k] >= kClipLevel);
        }
      }
      for (int k0 = 0; k0 < tw; k0 += kBlock) {
        const int kb = std::min(kBlock, tw - k0);
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < kb; ++j) {
            ys[size_t(j) * n + i] = lum[size_t(i) * tw + k0 + j];
            bad[size_t(j) * n + i] = clip[size_t(i) * tw + k0 + j];
          }
        for (int j = 0; j < kb; ++j) {
          const int k = k0 + j;
          const int64_t p = base + k;
          if (r.status[p] != kTexelOk) continue;
          double* y = ys.data() + size_t(j) * n;
          char* clipped = bad.data() + size_t(j) * n;
          auto sample = [&](int i, int c) { return vals[(size_t(c) * n + i) * tw + k]; };
          // Non-finite samples (NaN/Inf in any channel: dead pixels, decode holes) are never
          // used either; they rank as dark (y = 0), clipped ones keep their value.
          int finite = 0;
          for (int i = 0; i < n; ++i) {
            const bool f = std::isfinite(y[i]);
            finite += f;
            clipped[i] |= char(!f);
            y[i] = f ? y[i] : 0.0;
          }
          if (finite < 3) {
            r.status[p] = kTexelNonFinite;
            continue;
          }
          // 1. Rank trimming (keep at least 3 of the middle ranks): the samples ranked [lo, hi)
          // are those between the rank-lo and rank-hi keys (selections, no sort). Ties (shadow
          // zeros, 8-bit codes) break by index, so the kept set is deterministic.
          int lo = int(std::floor(kTrimDark * n)), hi = int(std::ceil((1 - kTrimBright) * n));
          if (hi - lo < 3) lo = std::max(0, std::min(lo, n - 3)), hi = std::min(n, lo + 3);
          std::copy_n(y, n, vals_sel.data());
          double v_lo = 0, v_hi = 0;
          if (hi < n)
            SelectTwo(vals_sel.data(), n, lo, hi, std::less<double>(), &v_lo, &v_hi);
          else
            v_lo = SelectKth(vals_sel.data(), n, lo);
          const RankKey first = KeyOfRank(y, n, v_lo, lo);
          const RankKey end = hi < n ? KeyOfRank(y, n, v_hi, hi) : RankKey{0, n};
          for (int i = 0; i < n; ++i) {
            const RankKey key{y[i], i};
            keep[i] = !clipped[i] && !ByValueThenIndex(key, first) &&
                      (hi == n || ByValueThenIndex(key, end));
          }
          Vec3 g;
          bool solved = SolveSubset(L, y, keep, &g, &m);
          // 2. Reweighting rounds.
          for (int round = 0; solved && round < kRounds; ++round) {
            const Vec3 nn = Normalize(g);
            for (int i = 0; i < n; ++i) {
              d[i] = std::max(0.0, g.x * L.x[i] + g.y * L.y[i] + g.z * L.z[i]);  // ŷ_i
              e[i] = std::abs(y[i] - d[i]);                                      // |r_i|
            }
            int count = 0;  // the inliers' |r|, compacted branch-free
            for (int i = 0; i < n; ++i) absr[count] = e[i], count += keep[i];
            const double sigma =
                1.4826 * SelectKth(absr.data(), count, count / 2) + 1e-3 * Length(g) + 1e-6;
            for (int i = 0; i < n; ++i)
              next[i] = char(!clipped[i] & (nn.x * L.x[i] + nn.y * L.y[i] + nn.z * L.z[i] > 0.05) &
                             (e[i] <= 3 * sigma));
            if (next == keep) break;
            Vec3 g2;
            if (!SolveSubset(L, y, next, &g2, &m2)) break;  // keep the last good subset
            keep.swap(next), g = g2, m = m2;
          }
          const int inliers = int(std::count(keep.begin(), keep.end(), 1));
          if (!solved || inliers < 3) {
            r.status[p] = kTexelTooFewLights;
            continue;
          }
          if (Conditioning(m) < 1e-3) {
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
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
