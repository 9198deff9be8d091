#include "core/pack/gltf_texel_fit.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

#include "core/check.h"
#include "core/pack/gltf_bake.h"
#include "core/simd_clones.h"

namespace matfit::gltf {

// ---- One texel ---------------------------------------------------------------------------

TexelFit::TexelFit(const CapLights& lights, const Mat3& inverse, const MsTable& table, int channels)
    : L(lights), inv(inverse), ms(table), ch(channels) {
  y.assign(size_t(3) * L.padded, 0.0f);
  d.resize(size_t(L.padded)), a.resize(size_t(L.padded)), b.resize(size_t(L.padded));
}

void TexelFit::SamplesSet() {
  for (int c = 0; c < ch; ++c) {
    yy[c] = 0;
    for (int k = 0; k < L.K; ++k)
      yy[c] += double(y[size_t(c * L.padded + k)]) * y[size_t(c * L.padded + k)];
  }
}

Vec3f TexelFit::LambertNormal(const std::vector<double>* lobe) const {
  double g[3] = {0, 0, 0};
  for (int k = 0; k < L.K; ++k) {
    const float* yk = y.data() + k;
    double v = ch == 3 ? 0.2126 * yk[0] + 0.7152 * yk[L.padded] + 0.0722 * yk[2 * L.padded] : yk[0];
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

// With ρ' = (1 − F0) ρ the model y_c = ρ'_c d + F0 a + b is linear in (ρ', F0).
TexelFit::Lobe TexelFit::Solve(const Vec3f& n, double r, float* residual) {
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
  const double f0 = ch * a_perp > 1e-12
                        ? SelfConsistentF0(y_perp / (ch * a_perp), (s.ba - proj * s.bd) / a_perp, c)
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
    out.err += yy[k] - 2 * kappa * s.yb[k] + bb - 2 * rp * zd[k] - 2 * f0 * za[k] + rp * rp * s.dd +
               2 * rp * f0 * ad + f0 * f0 * aa;
    if (residual)
      LobeResiduals(y.data() + size_t(k) * L.padded, d.data(), a.data(), b.data(), L.padded,
                    float(rp), float(kappa * f0), float(kappa), residual + size_t(k) * L.padded);
  }
  out.err = std::max(out.err, 0.0);
  return out;
}

TexelFit::Lobe TexelFit::BestOf(const Vec3f& n, const double* rs, int count) {
  Lobe best = Solve(n, rs[0]);
  for (int i = 1; i < count; ++i)
    if (Lobe l = Solve(n, rs[i]); l.err < best.err) best = l;
  return best;
}

TexelFit::Lobe TexelFit::BestLobe(const Vec3f& n) {
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

namespace {
constexpr double kDelta = 2e-3;  // the forward differences' step in slope
Vec3f AtSlopes(double x, double y) { return Normalize(Vec3f(float(x), float(y), 1.0f)); }
}  // namespace

// n ∝ (sx, sy, 1); the Jacobian by forward differences; two steps, a step that does not lower
// the residual halved once, and the search stops when that fails too (more steps and halvings
// change none of the figures in docs/pack.md, at 1.6× the cost).
Vec3f TexelFit::RefineNormal(Vec3f n, double r, Lobe* best, std::vector<float>* scratch) {
  // Residuals K per channel at stride `padded` (padded lights and channels past ch: zero).
  const size_t m = size_t(3) * L.padded;
  scratch->assign(3 * m, 0.0f);
  float *e0 = scratch->data(), *ex = e0 + m, *ey = ex + m;
  if (!(n.z > 0.05f)) return n;  // within 3° of the horizon: no slope to refine
  double sx = n.x / n.z, sy = n.y / n.z;
  *best = Solve(AtSlopes(sx, sy), r, e0);
  for (int iter = 0; iter < 2; ++iter) {
    (void)Solve(AtSlopes(sx + kDelta, sy), r, ex);
    (void)Solve(AtSlopes(sx, sy + kDelta), r, ey);
    double g[5];  // JᵀJ (xx, xy, yy) and Jᵀe (x, y), J by forward differences
    GaussNewtonSums(e0, ex, ey, int(m), float(1 / kDelta), g);
    const double det = g[0] * g[2] - g[1] * g[1];
    if (!(det > 1e-18)) break;
    double stx = -(g[2] * g[3] - g[1] * g[4]) / det, sty = -(g[0] * g[4] - g[1] * g[3]) / det;
    bool improved = false;
    for (int halve = 0; halve < 2 && !improved; ++halve) {
      if (Lobe l = Solve(AtSlopes(sx + stx, sy + sty), r, ex); l.err < best->err) {
        *best = l, sx += stx, sy += sty, improved = true;
        std::swap(e0, ex);
      } else {
        stx /= 2, sty /= 2;
      }
    }
    if (!improved || std::abs(stx) + std::abs(sty) < 1e-4) break;
  }
  return AtSlopes(sx, sy);
}

TexelFit::Lobe TexelFit::FitTexel(double r0, Vec3f* normal, std::vector<float>* scratch) {
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

// ---- Eight texels --------------------------------------------------------------------------

namespace {
constexpr int kB = BatchFit::kLanes;
bool Any(const bool* on) {
  bool any = false;
  for (int j = 0; j < kB; ++j) any |= on[j];
  return any;
}
}  // namespace

BatchFit::BatchFit(const CapLights& lights, const Mat3& inverse, const MsTable& table, int channels)
    : L_(lights),
      inv_(inverse),
      ms_(table),
      ch_(channels),
      y_(size_t(kB) * 3 * lights.padded, 0.0f),
      ylane_(y_.size(), 0.0f),
      a_(size_t(kB) * lights.padded),
      b_(a_.size()),
      d_(a_.size()),
      lobe_(size_t(kB) * lights.padded),
      e_(size_t(kB) * 3 * 3 * lights.padded, 0.0f) {}

void BatchFit::Load(int j, const float* pred, int stride) {
  const int P = L_.padded;
  float* y = Samples(j);
  for (int c = 0; c < ch_; ++c)
    for (int k = 0; k < L_.K; ++k) {
      const float v =
          FitSample(pred[(size_t(k) * ch_ + size_t(c)) * size_t(stride)], L_.sw[size_t(k)]);
      y[size_t(c * P + k)] = v, ylane_[size_t(c * P + k) * kB + size_t(j)] = v;
    }
}

namespace {

// The loops across the lanes, built for AVX-512 and AVX2 too (core/simd_clones.h): each lane's
// operations are TexelFit's, in its order, whatever the width.

// TexelFit::SamplesSet per lane: yy[c][j] = Σ_k y², in light order.
MATFIT_CLONES_V4 void LaneSquares(const float* ylane, int K, int P, int ch, double (*yy)[kB]) {
  for (int c = 0; c < ch; ++c) {
    double acc[kB] = {};
    for (int k = 0; k < K; ++k) {
      const float* yk = ylane + size_t(c * P + k) * kB;
      for (int j = 0; j < kB; ++j) acc[j] += double(yk[j]) * yk[j];
    }
    for (int j = 0; j < kB; ++j) yy[c][j] = acc[j];
  }
}

typedef double V8d __attribute__((vector_size(64)));
typedef float V8f __attribute__((vector_size(32)));
static_assert(kB == 8, "the lane loops below are written for 8 lanes");

// TexelFit::LambertNormal's sums over the lights per lane: g = Σ_k v_k l_k with
// v_k = (Y_k − lobe_k) / sw_k (Y the luminance, or the one channel); lobe may be null. In
// vector types: as lane loops over arrays GCC stored v between them and reloaded it in halves.
MATFIT_CLONES_V4 void LambertSums(const CapLights& L, const float* ylane, bool rgb,
                                  const double* lobe, double (*g)[kB]) {
  const int P = L.padded;
  V8d g0 = {}, g1 = {}, g2 = {};
  for (int k = 0; k < L.K; ++k) {
    V8f y0, y1, y2;
    std::memcpy(&y0, ylane + size_t(k) * kB, sizeof y0);
    V8d v = __builtin_convertvector(y0, V8d);
    if (rgb) {
      std::memcpy(&y1, ylane + size_t(P + k) * kB, sizeof y1);
      std::memcpy(&y2, ylane + size_t(2 * P + k) * kB, sizeof y2);
      v = 0.2126 * v + 0.7152 * __builtin_convertvector(y1, V8d) +
          0.0722 * __builtin_convertvector(y2, V8d);
    }
    if (lobe) {
      V8d l;
      std::memcpy(&l, lobe + size_t(k) * kB, sizeof l);
      v -= l;
    }
    v /= double(L.sw[size_t(k)]);
    g0 += v * double(L.lx[size_t(k)]), g1 += v * double(L.ly[size_t(k)]);
    g2 += v * double(L.lz[size_t(k)]);
  }
  std::memcpy(g[0], &g0, sizeof g0), std::memcpy(g[1], &g1, sizeof g1);
  std::memcpy(g[2], &g2, sizeof g2);
}

// Eight consecutive texels' samples: FitSample of pred[(k · ch + c) · stride + j] (j < 8) into
// ylane (across the lanes) and y (lane j at j · y_stride; channel c, light k at c · P + k).
MATFIT_CLONES_V4 void LoadEightLanes(const CapLights& L, int ch, const float* pred, int stride,
                                     float* ylane, float* y, size_t y_stride) {
  const int P = L.padded;
  for (int c = 0; c < ch; ++c)
    for (int k = 0; k < L.K; ++k) {
      const float* src = pred + (size_t(k) * ch + size_t(c)) * size_t(stride);
      float* dst = ylane + size_t(c * P + k) * kB;
      const float sw = L.sw[size_t(k)];
      for (int j = 0; j < kB; ++j) {
        const float v = src[j];
        const bool finite = v - v == 0;  // false for ±∞ and NaN
        const float cut = v < -1e3f ? -1e3f : (1e3f < v ? 1e3f : v);
        dst[j] = finite ? sw * cut : 0.0f;
      }
    }
  // Across the lanes → lane by lane, 8 × 8 blocks (lights k0 … k0 + 7 of one channel).
  for (int c = 0; c < ch; ++c)
    for (int k0 = 0; k0 < L.K; k0 += 8) {
      const int n = std::min(8, L.K - k0);
      V8f row[8];
      for (int i = 0; i < 8; ++i)
        std::memcpy(&row[i], ylane + size_t(c * P + k0 + std::min(i, n - 1)) * kB, sizeof row[i]);
      V8f col[8];  // col[j][i]: lane j, light k0 + i
      Transpose8x8(row, col);
      for (int j = 0; j < 8; ++j)
        std::memcpy(y + size_t(j) * y_stride + size_t(c * P + k0), &col[j], sizeof(float) * n);
    }
}

// e = y − rp d − fa a − fb b per channel (coefficients coef[c] = (rp, fa, fb)), P lights each.
MATFIT_CLONES_V4 void LaneResiduals(const float* __restrict y, const float* __restrict d,
                                    const float* __restrict a, const float* __restrict b, int P,
                                    int ch, const float (*coef)[3], float* __restrict e) {
  for (int c = 0; c < ch; ++c) {
    const float rp = coef[c][0], fa = coef[c][1], fb = coef[c][2];
    const float* yc = y + size_t(c) * P;
    float* ec = e + size_t(c) * P;
    for (int j = 0; j < P; ++j) ec[j] = yc[j] - rp * d[j] - fa * a[j] - fb * b[j];
  }
}

// The lanes' LobeSums, one array per sum.
struct LaneSums {
  double dd[kB], ad[kB], aa[kB], bd[kB], ba[kB], bb[kB];
  double yd[3][kB], ya[3][kB], yb[3][kB];
};

// TexelFit::Solve up to its F0: the projection of a on d and SelfConsistentF0's arguments u, v
// (valid where has[j]).
MATFIT_CLONES_V4 void F0Arguments(const LaneSums& s, int ch, double* proj, double* u, double* v,
                                  bool* has) {
  for (int j = 0; j < kB; ++j) {
    proj[j] = s.dd[j] > 0 ? s.ad[j] / s.dd[j] : 0;
    const double a_perp = s.aa[j] - proj[j] * s.ad[j];
    double y_perp = 0;
    for (int k = 0; k < ch; ++k) y_perp += s.ya[k][j] - proj[j] * s.yd[k][j];
    has[j] = ch * a_perp > 1e-12;
    u[j] = y_perp / (ch * a_perp), v[j] = (s.ba[j] - proj[j] * s.bd[j]) / a_perp;
  }
}

// TexelFit::Solve from F0 on: ρ per channel, the squared residual, and the residuals'
// coefficients (ρ', κ F0, κ) per channel.
MATFIT_CLONES_V4 void LobeFigures(const LaneSums& s, const double (*yy)[kB], int ch, double c,
                                  const double* f0, double* err, double (*rho)[kB],
                                  float (*coef)[3][kB]) {
  for (int j = 0; j < kB; ++j) {
    const double f = f0[j], kappa = 1 + f * c;
    const double ad = kappa * s.ad[j], aa = kappa * kappa * s.aa[j], bd = kappa * s.bd[j],
                 bb = kappa * kappa * s.bb[j], ba = kappa * kappa * s.ba[j];
    double e = 0;
    for (int k = 0; k < ch; ++k) {
      const double zd = s.yd[k][j] - bd, za = kappa * s.ya[k][j] - ba;
      const double r = s.dd[j] > 0 ? std::clamp((zd - f * ad) / s.dd[j] / (1 - f), 0.0, 1.0) : 0.0;
      const double rp = r * (1 - f);  // ρ'
      // Σ (y − κ b − ρ' d − F0 κ a)², expanded into the sums.
      e += yy[k][j] - 2 * kappa * s.yb[k][j] + bb - 2 * rp * zd - 2 * f * za + rp * rp * s.dd[j] +
           2 * rp * f * ad + f * f * aa;
      rho[k][j] = r;
      coef[k][0][j] = float(rp), coef[k][1][j] = float(kappa * f), coef[k][2][j] = float(kappa);
    }
    for (int k = ch; k < 3; ++k) rho[k][j] = 0;
    err[j] = std::max(e, 0.0);
  }
}

}  // namespace

void BatchFit::LoadEight(const float* pred, int stride) {
  LoadEightLanes(L_, ch_, pred, stride, ylane_.data(), y_.data(), Stride());
}

void BatchFit::LambertNormals(const double* lobe, const Mask on, float* nx, float* ny,
                              float* nz) const {
  double g[3][kB];
  LambertSums(L_, ylane_.data(), ch_ == 3, lobe, g);
  for (int j = 0; j < kB; ++j) {
    if (!on[j]) continue;
    double n[3];
    for (int i = 0; i < 3; ++i)
      n[i] = inv_[i][0] * g[0][j] + inv_[i][1] * g[1][j] + inv_[i][2] * g[2][j];
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 1e-9)) {
      nx[j] = 0, ny[j] = 0, nz[j] = 1;
      continue;
    }
    const double sign = n[2] < 0 ? -1 : 1;
    nx[j] = float(sign * n[0] / len), ny[j] = float(sign * n[1] / len);
    nz[j] = float(sign * n[2] / len);
  }
}

// TexelFit::Solve lane by lane: LobeRun per lane, then its closed form across the lanes.
void BatchFit::Solve(const float* nx, const float* ny, const float* nz, double r, const Mask on,
                     float* const* residual, Lobes* out) {
  const int P = L_.padded;
  LaneSums s = {};
  for (int j = 0; j < kB; ++j) {
    if (!on[j]) continue;
    LobeSums t;
    LobeRun(L_, Samples(j), nx[j], ny[j], std::max(nz[j], 1e-3f), float(r * r),
            a_.data() + size_t(j) * P, b_.data() + size_t(j) * P, d_.data() + size_t(j) * P, &t);
    s.dd[j] = t.dd, s.ad[j] = t.ad, s.aa[j] = t.aa, s.bd[j] = t.bd, s.ba[j] = t.ba, s.bb[j] = t.bb;
    for (int k = 0; k < 3; ++k) s.yd[k][j] = t.yd[k], s.ya[k][j] = t.ya[k], s.yb[k][j] = t.yb[k];
  }
  // The lobe is κ (F0 a + b) with κ = 1 + F0 c (multiple scattering).
  const double c = ms_(r);
  double proj[kB], u[kB], v[kB], f0[kB], err[kB], rho[3][kB];
  float coef[3][3][kB];
  bool has[kB];
  F0Arguments(s, ch_, proj, u, v, has);
  for (int j = 0; j < kB; ++j) f0[j] = on[j] && has[j] ? SelfConsistentF0(u[j], v[j], c) : 0.0;
  LobeFigures(s, yy_, ch_, c, f0, err, rho, coef);
  for (int j = 0; j < kB; ++j) {
    if (!on[j]) continue;
    out->f0[j] = f0[j], out->err[j] = err[j], out->r[j] = r;
    for (int k = 0; k < 3; ++k) out->rho[k][j] = rho[k][j];
    if (residual) {
      float lane_coef[3][3];
      for (int k = 0; k < ch_; ++k)
        for (int i = 0; i < 3; ++i) lane_coef[k][i] = coef[k][i][j];
      LaneResiduals(Samples(j), d_.data() + size_t(j) * P, a_.data() + size_t(j) * P,
                    b_.data() + size_t(j) * P, P, ch_, lane_coef, residual[j]);
    }
  }
}

void BatchFit::KeepLower(const Lobes& l, const Mask on, Lobes* best, bool* take) {
  for (int j = 0; j < kB; ++j) {
    take[j] = on[j] && l.err[j] < best->err[j];
    if (!take[j]) continue;
    best->f0[j] = l.f0[j], best->err[j] = l.err[j], best->r[j] = l.r[j];
    for (int k = 0; k < 3; ++k) best->rho[k][j] = l.rho[k][j];
  }
}

// TexelFit::RefineNormal lane by lane: every lane steps as it would alone; a lane that stops
// (no descent direction, no lower residual, a step below 1e-4) sits out the remaining solves.
void BatchFit::RefineNormals(const Mask on, double r, float* nx, float* ny, float* nz,
                             Lobes* best) {
  const int m = 3 * L_.padded;
  float *e0[kB], *ex[kB], *ey[kB];
  for (int j = 0; j < kB; ++j) {
    float* base = e_.data() + size_t(j) * 3 * size_t(m);
    e0[j] = base, ex[j] = base + m, ey[j] = base + 2 * m;
  }
  bool act[kB];
  double sx[kB] = {}, sy[kB] = {};
  for (int j = 0; j < kB; ++j) {
    act[j] = on[j] && nz[j] > 0.05f;  // within 3° of the horizon: no slope to refine
    if (act[j]) sx[j] = nx[j] / nz[j], sy[j] = ny[j] / nz[j];
  }
  if (!Any(act)) return;
  // The normals a solve is made at, for the lanes asked: n(sx, sy), n(sx + δ, sy), n(sx, sy + δ)
  // or n(sx + stx, sy + sty), each computed as TexelFit::RefineNormal computes it.
  enum Point { kHere, kDx, kDy, kStep };
  float px[kB], py[kB], pz[kB];
  double stx[kB] = {}, sty[kB] = {};
  auto at = [&](const bool* lanes, Point point) {
    for (int j = 0; j < kB; ++j) {
      if (!lanes[j]) continue;
      const Vec3f n = point == kHere ? AtSlopes(sx[j], sy[j])
                      : point == kDx ? AtSlopes(sx[j] + kDelta, sy[j])
                      : point == kDy ? AtSlopes(sx[j], sy[j] + kDelta)
                                     : AtSlopes(sx[j] + stx[j], sy[j] + sty[j]);
      px[j] = n.x, py[j] = n.y, pz[j] = n.z;
    }
  };
  Lobes l;
  bool take[kB];
  at(act, kHere);
  Solve(px, py, pz, r, act, e0, &l);
  for (int j = 0; j < kB; ++j)
    if (act[j]) {
      best->f0[j] = l.f0[j], best->err[j] = l.err[j], best->r[j] = l.r[j];
      for (int k = 0; k < 3; ++k) best->rho[k][j] = l.rho[k][j];
    }
  bool go[kB];
  std::copy(act, act + kB, go);
  for (int iter = 0; iter < 2 && Any(go); ++iter) {
    at(go, kDx);
    Solve(px, py, pz, r, go, ex, &l);
    at(go, kDy);
    Solve(px, py, pz, r, go, ey, &l);
    bool improved[kB] = {};
    for (int j = 0; j < kB; ++j) {
      if (!go[j]) continue;
      double g[5];  // JᵀJ (xx, xy, yy) and Jᵀe (x, y)
      GaussNewtonSums(e0[j], ex[j], ey[j], m, float(1 / kDelta), g);
      const double det = g[0] * g[2] - g[1] * g[1];
      if (!(det > 1e-18)) {
        go[j] = false;
        continue;
      }
      stx[j] = -(g[2] * g[3] - g[1] * g[4]) / det, sty[j] = -(g[0] * g[4] - g[1] * g[3]) / det;
    }
    for (int halve = 0; halve < 2; ++halve) {
      bool tries[kB];
      for (int j = 0; j < kB; ++j) tries[j] = go[j] && !improved[j];
      if (!Any(tries)) break;
      at(tries, kStep);
      Solve(px, py, pz, r, tries, ex, &l);
      KeepLower(l, tries, best, take);
      for (int j = 0; j < kB; ++j) {
        if (!tries[j]) continue;
        if (take[j]) {
          sx[j] += stx[j], sy[j] += sty[j], improved[j] = true;
          std::swap(e0[j], ex[j]);
        } else {
          stx[j] /= 2, sty[j] /= 2;
        }
      }
    }
    for (int j = 0; j < kB; ++j)
      if (go[j] && (!improved[j] || std::abs(stx[j]) + std::abs(sty[j]) < 1e-4)) go[j] = false;
  }
  at(act, kHere);
  for (int j = 0; j < kB; ++j)
    if (act[j]) nx[j] = px[j], ny[j] = py[j], nz[j] = pz[j];
}

void BatchFit::Fit(int lanes, double r0, Result* out) {
  MATFIT_CHECK(r0 > 0 && lanes >= 0 && lanes <= kB, "BatchFit::Fit: a roughness and 0-8 lanes");
  LaneSquares(ylane_.data(), L_.K, L_.padded, ch_, yy_);
  bool all[kB];
  for (int j = 0; j < kB; ++j) all[j] = j < lanes;
  float nx[kB] = {}, ny[kB] = {}, nz[kB] = {};
  LambertNormals(nullptr, all, nx, ny, nz);
  Lobes best;
  Solve(nx, ny, nz, r0, all, nullptr, &best);
  bool lobed[kB], take[kB];
  for (int j = 0; j < kB; ++j) lobed[j] = all[j] && best.f0[j] > 0;
  if (Any(lobed)) {
    // The lobe of that solve (its a, b), and the normal of what it leaves.
    for (int j = 0; j < kB; ++j) {
      if (!lobed[j]) continue;
      const double kappa = 1 + best.f0[j] * ms_(best.r[j]);
      const float *a = a_.data() + size_t(j) * L_.padded, *b = b_.data() + size_t(j) * L_.padded;
      for (int k = 0; k < L_.K; ++k)
        lobe_[size_t(k) * kB + size_t(j)] = kappa * (best.f0[j] * a[k] + b[k]);
    }
    float mx[kB] = {}, my[kB] = {}, mz[kB] = {};
    LambertNormals(lobe_.data(), lobed, mx, my, mz);
    Lobes l;
    Solve(mx, my, mz, r0, lobed, nullptr, &l);
    KeepLower(l, lobed, &best, take);
    for (int j = 0; j < kB; ++j)
      if (take[j]) nx[j] = mx[j], ny[j] = my[j], nz[j] = mz[j];
    RefineNormals(lobed, r0, nx, ny, nz, &best);
    // TexelFit::BestOf over r0 / 1.25 and min(1, 1.25 r0) (at most 1: the texture holds r in
    // [0, 1]), then kept where lower.
    const double others[] = {r0 / 1.25, std::min(1.0, r0 * 1.25)};
    Lobes bo;
    Solve(nx, ny, nz, others[0], lobed, nullptr, &bo);
    if (r0 < 1) {
      Solve(nx, ny, nz, others[1], lobed, nullptr, &l);
      KeepLower(l, lobed, &bo, take);
    }
    KeepLower(bo, lobed, &best, take);
  }
  for (int j = 0; j < lanes; ++j) {
    Result& o = out[j];
    o.normal[0] = nx[j], o.normal[1] = ny[j], o.normal[2] = nz[j];
    o.r = best.r[j], o.f0 = best.f0[j];
    for (int c = 0; c < 3; ++c) o.rho[c] = best.rho[c][j];
  }
}

}  // namespace matfit::gltf
