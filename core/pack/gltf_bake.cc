#include "core/pack/gltf_bake.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <numbers>
#include <vector>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/simd_clones.h"

namespace matfit {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

// Rings every kSpacing from the zenith to θ = 60°, each with its directions about kSpacing apart.
std::vector<Vec3f> CapDirections() {
  constexpr double kSpacing = 12;  // degrees: 85 directions
  std::vector<Vec3f> dirs{Vec3f(0, 0, 1)};
  for (int ring = 1; ring * kSpacing <= 60.01; ++ring) {
    const double t = ring * kSpacing * kDeg;
    const int count =
        std::max(6, int(std::lround(2 * std::numbers::pi * std::sin(t) / (kSpacing * kDeg))));
    for (int k = 0; k < count; ++k) {
      const double p = 2 * std::numbers::pi * k / count;
      dirs.push_back(Vec3f(float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)),
                           float(std::cos(t))));
    }
  }
  return dirs;
}

using Mat3 = std::array<std::array<double, 3>, 3>;

// (Σ_k l_k l_kᵀ)⁻¹ by cofactors: the directions span the cap, so it is well conditioned.
Mat3 InverseScatter(const std::vector<Vec3f>& dirs) {
  Mat3 a{};
  for (const Vec3f& l : dirs)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] += double((&l.x)[i]) * double((&l.x)[j]);
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  Mat3 inv;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      inv[i][j] = (a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]) / det;
    }
  return inv;
}

// 1/E − 1 on r = 0, 1/64, …, 1 (linear in between; r = 0 repeats r = 1/64).
struct MsTable {
  static constexpr int kSteps = 64;
  double c[kSteps + 1];
  MsTable() {  // 65 quadratures of 4096 steps (≈ 10 ms on one thread): the entries in parallel
    ParallelFor(0, kSteps + 1, [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i)
        c[i] = 1 / GgxAlbedoHeadOn(double(std::max<int64_t>(i, 1)) / kSteps) - 1;
    });
  }
  double operator()(double r) const {
    const double x = std::clamp(r, 0.0, 1.0) * kSteps;
    const int i = std::min(int(x), kSteps - 1);
    return c[i] + (x - i) * (c[i + 1] - c[i]);
  }
};

// The process's table, computed on first use. Not a function-local static: its initialisation
// would hold a lock while its ParallelFor runs, and a thread waiting there may run another
// caller's range that needs the table (a recursive initialisation). Instead each first caller
// computes one with no lock held and the first to finish publishes it (kept for the process).
const MsTable& SharedMsTable() {
  static std::atomic<const MsTable*> shared{nullptr};  // constant-initialised: no guard
  if (const MsTable* t = shared.load(std::memory_order_acquire)) return *t;
  auto fresh = std::make_unique<const MsTable>();
  const MsTable* expected = nullptr;
  if (shared.compare_exchange_strong(expected, fresh.get(), std::memory_order_acq_rel))
    return *fresh.release();
  return *expected;  // another thread published first
}

// The cap's lights in SoA, padded to a multiple of 8 with lights below the horizon (zero
// diffuse and lobe: they add nothing to any sum).
struct CapLights {
  int K = 0, padded = 0;
  std::vector<float> lx, ly, lz, hx, hy, hz, w;  // direction, half vector, (1 − v·h)^5
  std::vector<float> sw;                         // √ of the light's weight in the fit
  explicit CapLights(const std::vector<Vec3f>& dirs) : K(int(dirs.size())) {
    padded = (K + 7) / 8 * 8;
    const Vec3f v(0, 0, 1);
    for (int k = 0; k < padded; ++k) {
      const Vec3f l = k < K ? dirs[size_t(k)] : Vec3f(0, 0, -1);
      const Vec3f h = k < K ? Normalize(l + v) : Vec3f(0, 0, 1);
      lx.push_back(l.x), ly.push_back(l.y), lz.push_back(l.z);
      hx.push_back(h.x), hy.push_back(h.y), hz.push_back(h.z);
      w.push_back(k < K ? shading::SchlickFresnel(0.0f, Dot(v, h)) : 0.0f);
      sw.push_back(k < K ? std::sqrt(l.z) : 0.0f);  // weight cos θ: the light's irradiance
    }
  }
};

// Σ_k of the products the least squares need (y the samples, d the diffuse shape, a and b the
// lobe's F0 part and rest).
struct LobeSums {
  double dd = 0, ad = 0, aa = 0, bd = 0, ba = 0, bb = 0;
  double yd[3] = {}, ya[3] = {}, yb[3] = {};
};

// The lobe of shading::CookTorranceSpecularHalf at F0 = 1 (GgxD, GgxG1 and the Fresnel weight,
// branch-free over the lights so that it vectorises) split into a = lobe (1 − w) and b = lobe w,
// the diffuse shape d = (1 − w) max(0, n·l), and their sums with the samples y (channel c at
// y + c · padded). View straight down: n·v = n_z > 0.
MATFIT_CLONES_V4 void LobeRun(const CapLights& L, const float* y, float nx, float ny, float nz,
                              float alpha, float* __restrict a, float* __restrict b,
                              float* __restrict d, LobeSums* s) {
  const float g1v = shading::GgxG1(nz, alpha), scale = float(M_PI) * g1v / (4 * nz);
  const float *lx = L.lx.data(), *ly = L.ly.data(), *lz = L.lz.data(), *hx = L.hx.data(),
              *hy = L.hy.data(), *hz = L.hz.data(), *w = L.w.data(), *sw = L.sw.data();
  const int np = L.padded;
  for (int k = 0; k < np; ++k) {
    const float nl = nx * lx[k] + ny * ly[k] + nz * lz[k],
                nh = nx * hx[k] + ny * hy[k] + nz * hz[k];
    // max(0, x) as (x + |x|) / 2: GCC 12 vectorises neither the ternary nor fmaxf here.
    const float nlc = 0.5f * (nl + std::fabs(nl)), nhc = 0.5f * (nh + std::fabs(nh));
    // G1(0) = 0: a light below the horizon gets no lobe without a branch.
    const float lobe = scale * shading::GgxD(nhc, alpha) * shading::GgxG1(nlc, alpha);
    a[k] = sw[k] * lobe * (1 - w[k]), b[k] = sw[k] * lobe * w[k], d[k] = sw[k] * nlc * (1 - w[k]);
  }
  // Lane-wise partial sums in double (no reassociation needed to vectorise; float sums lose
  // the residual of a sharp lobe, whose peak terms reach 1e4), then added across lanes.
  constexpr int kLanes = 8, kTerms = 15;
  double acc[kTerms][kLanes] = {};
  const float *y0 = y, *y1 = y + np, *y2 = y + 2 * np;  // channels past ch are zero
  for (int k0 = 0; k0 < np; k0 += kLanes)
    for (int j = 0; j < kLanes; ++j) {
      const int k = k0 + j;
      const double dk = d[k], ak = a[k], bk = b[k], y0k = y0[k], y1k = y1[k], y2k = y2[k];
      acc[0][j] += dk * dk, acc[1][j] += ak * dk, acc[2][j] += ak * ak;
      acc[3][j] += bk * dk, acc[4][j] += bk * ak, acc[5][j] += bk * bk;
      acc[6][j] += y0k * dk, acc[9][j] += y0k * ak, acc[12][j] += y0k * bk;
      acc[7][j] += y1k * dk, acc[10][j] += y1k * ak, acc[13][j] += y1k * bk;
      acc[8][j] += y2k * dk, acc[11][j] += y2k * ak, acc[14][j] += y2k * bk;
    }
  double t[kTerms] = {};
  for (int i = 0; i < kTerms; ++i)
    for (int j = 0; j < kLanes; ++j) t[i] += acc[i][j];
  s->dd = t[0], s->ad = t[1], s->aa = t[2], s->bd = t[3], s->ba = t[4], s->bb = t[5];
  for (int c = 0; c < 3; ++c) s->yd[c] = t[6 + c], s->ya[c] = t[9 + c], s->yb[c] = t[12 + c];
}

// g = (Σ jx², Σ jx jy, Σ jy², Σ jx e0, Σ jy e0) with jx = (ex − e0) · inv_delta (jy alike),
// over m residuals (a multiple of 8), lane-wise in float like LobeRun.
MATFIT_CLONES_V3 void GaussNewtonSums(const float* __restrict e0, const float* __restrict ex,
                                      const float* __restrict ey, int m, float inv_delta,
                                      double* g) {
  constexpr int kLanes = 8;
  float acc[5][kLanes] = {};
  for (int i0 = 0; i0 < m; i0 += kLanes)
    for (int j = 0; j < kLanes; ++j) {
      const int i = i0 + j;
      const float jx = (ex[i] - e0[i]) * inv_delta, jy = (ey[i] - e0[i]) * inv_delta;
      acc[0][j] += jx * jx, acc[1][j] += jx * jy, acc[2][j] += jy * jy;
      acc[3][j] += jx * e0[i], acc[4][j] += jy * e0[i];
    }
  for (int t = 0; t < 5; ++t) {
    g[t] = 0;
    for (int j = 0; j < kLanes; ++j) g[t] += acc[t][j];
  }
}

// One texel's samples y (channel c at y[c · padded + k]; K lights, `ch` channels: 1 or 3) and
// the fits of the glTF dielectric to them.
struct TexelFit {
  const CapLights& L;
  const Mat3& inv;
  const MsTable& ms;
  int ch;
  std::vector<float> y;
  double yy[3] = {};  // Σ_k y²
  // Scratch per light: the diffuse shape, the lobe's F0 part and rest of the last Solve.
  std::vector<float> d, a, b;
  std::vector<double> lobe;  // the fitted lobe per light (FitTexel's scratch)

  TexelFit(const CapLights& lights, const Mat3& inverse, const MsTable& table, int channels)
      : L(lights), inv(inverse), ms(table), ch(channels) {
    y.assign(size_t(3) * L.padded, 0.0f);
    d.resize(size_t(L.padded)), a.resize(size_t(L.padded)), b.resize(size_t(L.padded));
  }
  void SamplesSet() {
    for (int c = 0; c < ch; ++c) {
      yy[c] = 0;
      for (int k = 0; k < L.K; ++k)
        yy[c] += double(y[size_t(c * L.padded + k)]) * y[size_t(c * L.padded + k)];
    }
  }

  // The unit normal of the least-squares Lambertian of the luminance of y − lobe.
  Vec3f LambertNormal(const std::vector<double>* lobe) const {
    double g[3] = {0, 0, 0};
    for (int k = 0; k < L.K; ++k) {
      const float* yk = y.data() + k;
      double v =
          ch == 3 ? 0.2126 * yk[0] + 0.7152 * yk[L.padded] + 0.0722 * yk[2 * L.padded] : yk[0];
      if (lobe) v -= (*lobe)[size_t(k)];
      v /= L.sw[size_t(k)];
      g[0] += v * L.lx[size_t(k)], g[1] += v * L.ly[size_t(k)], g[2] += v * L.lz[size_t(k)];
    }
    double n[3];
    for (int i = 0; i < 3; ++i) n[i] = inv[i][0] * g[0] + inv[i][1] * g[1] + inv[i][2] * g[2];
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 1e-9)) return Vec3f(0, 0, 1);
    const double sign = n[2] < 0 ? -1 : 1;
    return Vec3f(float(sign * n[0] / len), float(sign * n[1] / len), float(sign * n[2] / len));
  }

  struct Lobe {
    double r = 1, f0 = 0, err = 0;
    double rho[3] = {0, 0, 0};
  };

  // The least-squares (ρ, F0) of shading::GltfDielectricHalf for normal n and roughness r, its
  // squared residual, and (when `residual` is given) the residuals, K per channel. With
  // ρ' = (1 − F0) ρ the model y_c = ρ'_c d + F0 a + b is linear in (ρ', F0).
  Lobe Solve(const Vec3f& n, double r, float* residual = nullptr) {
    LobeSums s;
    LobeRun(L, y.data(), n.x, n.y, std::max(n.z, 1e-3f), float(r * r), a.data(), b.data(), d.data(),
            &s);
    // The lobe is κ (F0 a + b) with κ = 1 + F0 c (multiple scattering): F0 from what the
    // diffuse shape leaves (a⊥ = a − (a·d / d·d) d, alike in every channel), self-consistent
    // with κ (SelfConsistentF0).
    const double c = ms(r);
    Lobe out;
    out.r = r;
    const double proj = s.dd > 0 ? s.ad / s.dd : 0, a_perp = s.aa - proj * s.ad;
    double y_perp = 0;
    for (int k = 0; k < ch; ++k) y_perp += s.ya[k] - proj * s.yd[k];
    const double f0 = ch * a_perp > 1e-12 ? SelfConsistentF0(y_perp / (ch * a_perp),
                                                             (s.ba - proj * s.bd) / a_perp, c)
                                          : 0.0;
    out.f0 = f0;
    const double kappa = 1 + f0 * c;
    double zd[3], za[3];
    const double ad = kappa * s.ad, aa = kappa * kappa * s.aa, bd = kappa * s.bd,
                 bb = kappa * kappa * s.bb, ba = kappa * kappa * s.ba;
    for (int k = 0; k < ch; ++k) {
      zd[k] = s.yd[k] - bd, za[k] = kappa * s.ya[k] - ba;
      out.rho[k] = s.dd > 0 ? std::clamp((zd[k] - f0 * ad) / s.dd / (1 - f0), 0.0, 1.0) : 0.0;
      const double rp = out.rho[k] * (1 - f0);  // ρ'
      // Σ (y − κ b − ρ' d − F0 κ a)², expanded into the sums.
      out.err += yy[k] - 2 * kappa * s.yb[k] + bb - 2 * rp * zd[k] - 2 * f0 * za[k] +
                 rp * rp * s.dd + 2 * rp * f0 * ad + f0 * f0 * aa;
      if (residual) {
        const float rpf = float(rp), fa = float(kappa * f0), fb = float(kappa),
                    *yc = y.data() + size_t(k) * L.padded;
        float* e = residual + size_t(k) * L.padded;
        for (int j = 0; j < L.padded; ++j) e[j] = yc[j] - rpf * d[j] - fa * a[j] - fb * b[j];
      }
    }
    out.err = std::max(out.err, 0.0);
    return out;
  }

  // The roughness of least residual among `rs`.
  Lobe BestOf(const Vec3f& n, const double* rs, int count) {
    Lobe best = Solve(n, rs[0]);
    for (int i = 1; i < count; ++i)
      if (Lobe l = Solve(n, rs[i]); l.err < best.err) best = l;
    return best;
  }

  // The roughness of least residual: a grid, then golden-section search around its best.
  Lobe BestLobe(const Vec3f& n) {
    constexpr double kGrid[] = {0.08, 0.15, 0.25, 0.35, 0.45, 0.6, 0.8, 1.0};
    Lobe best = Solve(n, kGrid[0]);
    int at = 0;
    for (int i = 1; i < 8; ++i)
      if (Lobe l = Solve(n, kGrid[i]); l.err < best.err) best = l, at = i;
    if (best.f0 <= 0) return best;
    double lo = kGrid[std::max(0, at - 1)], hi = kGrid[std::min(7, at + 1)];
    const double phi = (std::sqrt(5.0) - 1) / 2;
    double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
    Lobe l1 = Solve(n, x1), l2 = Solve(n, x2);
    while (hi - lo > 0.02) {
      if (l1.err < l2.err)
        hi = x2, x2 = x1, l2 = l1, x1 = hi - phi * (hi - lo), l1 = Solve(n, x1);
      else
        lo = x1, x1 = x2, l1 = l2, x2 = lo + phi * (hi - lo), l2 = Solve(n, x2);
    }
    for (const Lobe& l : {l1, l2})
      if (l.err < best.err) best = l;
    return best;
  }

  // Gauss–Newton on the normal's slopes (n ∝ (sx, sy, 1)) at roughness r, (ρ, F0) re-solved at
  // every step (variable projection), the Jacobian by forward differences; two steps, a step
  // that does not lower the residual halved once, and the search stops when that fails too
  // (more steps and halvings change none of the figures in docs/pack.md, at 1.6× the cost).
  Vec3f RefineNormal(Vec3f n, double r, Lobe* best, std::vector<float>* scratch) {
    // Residuals K per channel at stride `padded` (padded lights and channels past ch: zero).
    const size_t m = size_t(3) * L.padded;
    scratch->assign(3 * m, 0.0f);
    float *e0 = scratch->data(), *ex = e0 + m, *ey = ex + m;
    if (!(n.z > 0.05f)) return n;  // within 3° of the horizon: no slope to refine
    double sx = n.x / n.z, sy = n.y / n.z;
    auto at = [](double x, double yy) { return Normalize(Vec3f(float(x), float(yy), 1.0f)); };
    constexpr double kDelta = 2e-3;
    *best = Solve(at(sx, sy), r, e0);
    for (int iter = 0; iter < 2; ++iter) {
      (void)Solve(at(sx + kDelta, sy), r, ex);
      (void)Solve(at(sx, sy + kDelta), r, ey);
      double g[5];  // JᵀJ (xx, xy, yy) and Jᵀe (x, y), J by forward differences
      GaussNewtonSums(e0, ex, ey, int(m), float(1 / kDelta), g);
      const double det = g[0] * g[2] - g[1] * g[1];
      if (!(det > 1e-18)) break;
      double stx = -(g[2] * g[3] - g[1] * g[4]) / det, sty = -(g[0] * g[4] - g[1] * g[3]) / det;
      bool improved = false;
      for (int halve = 0; halve < 2 && !improved; ++halve) {
        if (Lobe l = Solve(at(sx + stx, sy + sty), r, ex); l.err < best->err) {
          *best = l, sx += stx, sy += sty, improved = true;
          std::swap(e0, ex);
        } else {
          stx /= 2, sty /= 2;
        }
      }
      if (!improved || std::abs(stx) + std::abs(sty) < 1e-4) break;
    }
    return at(sx, sy);
  }

  // Every step for one texel at roughness r0 (or searched when r0 ≤ 0): the Lambertian normal,
  // the lobe, the normal of what the lobe leaves, the normal of least residual, the lobe again.
  Lobe FitTexel(double r0, Vec3f* normal, std::vector<float>* scratch) {
    Vec3f n = LambertNormal(nullptr);
    Lobe best = r0 > 0 ? Solve(n, r0) : BestLobe(n);
    if (best.f0 > 0) {
      if (r0 <= 0) (void)Solve(n, best.r);  // a, b of that lobe
      lobe.resize(size_t(L.K));
      const double kappa = 1 + best.f0 * ms(best.r);
      for (size_t k = 0; k < size_t(L.K); ++k) lobe[k] = kappa * (best.f0 * a[k] + b[k]);
      const Vec3f n2 = LambertNormal(&lobe);
      if (Lobe l = Solve(n2, best.r); l.err < best.err) best = l, n = n2;
      n = RefineNormal(n, best.r, &best, scratch);
      if (r0 > 0) {
        // At most 1: the texture holds r in [0, 1].
        const double others[] = {r0 / 1.25, std::min(1.0, r0 * 1.25)};
        if (Lobe l = BestOf(n, others, r0 < 1 ? 2 : 1); l.err < best.err) best = l;
      } else if (Lobe l = BestLobe(n); l.err < best.err) {
        best = l;
      }
    }
    *normal = n;
    return best;
  }
};

}  // namespace

GltfBake BakeBasisAsGgx(const MaterialMaps& m, const ProgressFn& progress) {
  const std::vector<Vec3f> dirs = CapDirections();
  const CapLights lights(dirs);
  const int K = int(dirs.size()), ch = m.albedo.channels() == 3 ? 3 : 1;
  const Mat3 inv = InverseScatter(dirs);
  const MsTable& ms_table = SharedMsTable();
  const BatchEvaluator eval(m, dirs, Vec3f(0, 0, 1));
  const int64_t n = int64_t(m.width) * m.height;
  constexpr int kRun = 256;
  struct Worker {
    std::vector<float> pred;  // the model's prediction for a run: [k][c][t]
    std::vector<float> scratch;
    TexelFit fit;
  };
  auto make_worker = [&] {
    return Worker{
        std::vector<float>(size_t(K) * ch * kRun), {}, TexelFit(lights, inv, ms_table, ch)};
  };
  // Predicts the run p0 … p0 + len − 1 (when t = 0) and loads texel p0 + t into the fit.
  auto predict = [&](Worker& w, int64_t p0, int len) {
    for (int k = 0; k < K; ++k) eval.Evaluate(k, p0, len, ch, w.pred.data() + size_t(k) * ch * len);
  };
  // Loads texel t of the run predicted last. A texel without an estimate (NaN) bakes to black;
  // values past ±1e3 (a hostile pack) are cut there, so that no sum overflows.
  auto load = [&](Worker& w, int len, int t) {
    for (int c = 0; c < ch; ++c)
      for (int k = 0; k < K; ++k) {
        const float y = w.pred[(size_t(k) * ch + c) * len + t];
        w.fit.y[size_t(c * lights.padded + k)] =
            std::isfinite(y) ? lights.sw[size_t(k)] * std::clamp(y, -1e3f, 1e3f) : 0.0f;
      }
    w.fit.SamplesSet();
  };
  // The material's roughness: the median of full searches on up to 1024 texels spread over the
  // image (inside the mask), where a lobe is found. Texels then search only around it.
  const auto in_mask = [&](int64_t p) { return m.mask.empty() || m.mask.Plane(0)[p] > 0.5f; };
  std::vector<int64_t> sample;
  const int64_t stride = std::max<int64_t>(1, (n + 1023) / 1024);
  for (int64_t p = stride / 2; p < n; p += stride)
    if (in_mask(p)) sample.push_back(p);
  std::vector<double> sample_r(sample.size(), -1);
  ParallelFor(0, int64_t(sample.size()), [&](int64_t i0, int64_t i1) {
    Worker w = make_worker();
    for (int64_t i = i0; i < i1; ++i) {
      predict(w, sample[size_t(i)], 1);
      load(w, 1, 0);
      Vec3f nn;
      const TexelFit::Lobe l = w.fit.FitTexel(0, &nn, &w.scratch);
      if (l.f0 > 0.005) sample_r[size_t(i)] = l.r;
    }
  });
  std::vector<double> rs;
  for (double r : sample_r)
    if (r > 0) rs.push_back(r);
  double r_material = 0.5;
  if (!rs.empty()) {
    std::nth_element(rs.begin(), rs.begin() + long(rs.size() / 2), rs.end());
    r_material = rs[rs.size() / 2];
  }
  GltfBake out;
  out.base = Image(m.width, m.height, 3);
  out.normal = Image(m.width, m.height, 3);
  out.f0 = Image(m.width, m.height, 1);
  out.roughness = Image(m.width, m.height, 1);
  const int64_t runs = (n + kRun - 1) / kRun;
  std::atomic<int64_t> runs_done{0};
  std::mutex progress_mutex;
  ParallelFor(0, runs, [&](int64_t r0, int64_t r1) {
    Worker w = make_worker();
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kRun;
      const int len = int(std::min<int64_t>(kRun, n - p0));
      predict(w, p0, len);
      for (int t = 0; t < len; ++t) {
        const int64_t p = p0 + t;
        if (!in_mask(p)) {  // outside the sample: black, facing up, no lobe
          out.normal.Plane(2)[p] = 1, out.roughness.Plane(0)[p] = 1;
          continue;
        }
        load(w, len, t);
        Vec3f nn;
        const TexelFit::Lobe best = w.fit.FitTexel(r_material, &nn, &w.scratch);
        out.normal.Plane(0)[p] = nn.x, out.normal.Plane(1)[p] = nn.y, out.normal.Plane(2)[p] = nn.z;
        for (int c = 0; c < 3; ++c) out.base.Plane(c)[p] = float(best.rho[std::min(c, ch - 1)]);
        out.f0.Plane(0)[p] = float(best.f0);
        out.roughness.Plane(0)[p] = float(best.r);
      }
      const int64_t d = ++runs_done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        (void)progress(d, runs);
      }
    }
  });
  return out;
}

double GgxAlbedoHeadOn(double roughness) {
  roughness = std::clamp(roughness, 1.0 / 64, 1.0);  // sharper lobes: below float n·h resolution
  // E = 2 ∫_0^{π/2} R_s(θ) sin θ dθ with θ = (π/2) u² (dense where sharp lobes are), midpoints.
  constexpr int kSteps = 4096;
  const Vec3f n(0, 0, 1);
  double e = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double u = (i + 0.5) / kSteps, t = std::numbers::pi / 2 * u * u;
    const Vec3f l(float(std::sin(t)), 0, float(std::cos(t)));
    e += shading::CookTorranceSpecular(1.0f, float(roughness), n, l, n) * std::sin(t) *
         (std::numbers::pi * u / kSteps);
  }
  return 2 * e;
}

double SelfConsistentF0(double u, double v, double c) {
  const double g0 = u - v;  // F0 at κ = 1
  if (!(g0 > 0)) return 0;
  if (c == 0) return std::min(g0, 0.81);
  // c > 0: the positive root (the roots' product (v − u) / c is negative), without cancellation
  // as 2 g0 / (lin + √disc) when lin ≥ 0. c < 0 (a quadrature E(r) a hair above 1): the root that
  // tends to g0 as c → 0, the same expression. The point the iteration F0 ← u / κ − v reaches
  // when it converges (at |slope| ≥ 1 it oscillates instead).
  const double lin = 1 + c * v, disc = lin * lin + 4 * c * g0;
  double f0;
  if (c > 0)
    f0 = lin >= 0 ? 2 * g0 / (lin + std::sqrt(disc)) : (std::sqrt(disc) - lin) / (2 * c);
  else
    f0 = disc >= 0 && lin > 0 ? 2 * g0 / (lin + std::sqrt(disc)) : g0;
  return std::min(f0, 0.81);
}

GltfF0 SplitF0ForGltf(const Image& f0, const Image& mask) {
  GltfF0 out;
  if (f0.empty()) return out;
  std::vector<float> sorted;
  sorted.reserve(size_t(f0.plane_size()));
  const bool masked = mask.plane_size() == f0.plane_size();
  for (int64_t p = 0; p < f0.plane_size(); ++p)
    if (const float x = f0.Plane(0)[p]; std::isfinite(x) && (!masked || mask.Plane(0)[p] > 0.5f))
      sorted.push_back(std::max(0.0f, x));
  if (sorted.empty()) return out;
  const size_t k = std::min(sorted.size() - 1, sorted.size() * 99 / 100);
  std::nth_element(sorted.begin(), sorted.begin() + long(k), sorted.end());
  const double ref = std::min(double(sorted[k]), 0.81);
  if (!(ref > 0)) return out;
  const double r0 = std::sqrt(ref);
  out.ior = (1 + r0) / (1 - r0);
  out.share = Image(f0.width(), f0.height(), 1);
  for (int64_t p = 0; p < f0.plane_size(); ++p) {
    const float x = f0.Plane(0)[p];
    out.share.Plane(0)[p] = std::isfinite(x) ? float(std::clamp(x / ref, 0.0, 1.0)) : 0.0f;
  }
  return out;
}

}  // namespace matfit
