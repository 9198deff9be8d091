// `lambert`: classic photometric stereo with one precomputed pseudo-inverse for all texels.
//
// One pass over the planes: per channel g_c = P · (p_c / I_c) with P = (LᵀL)⁻¹Lᵀ (3 × N, shared);
// the normal is n = g/|g| of the luminance g = Σ_c luma_c g_c (linear in g_c), and the albedo is
// the least-squares ρ_c of p_c ≈ ρ_c L n for that n: ρ_c = nᵀ(Lᵀp_c) / nᵀMn = nᵀM g_c / nᵀMn
// with M = LᵀL, so it needs no second pass over the data.
// A texel with a clipped or non-finite sample is fitted again from its valid lights V alone
// (fit/valid_refit.h): the same formulas with M_V = Σ_V l lᵀ and g_c = M_V⁻¹ Σ_V l p_c / I_c.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/light_matrix.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "fit/valid_refit.h"

namespace matfit::fit {

namespace {

// The light set V of a refitted texel must determine a normal: at least 3 lights, and
// λ_min / λ_max of M_V = Σ_V l lᵀ at least this (lambert-robust's bound).
constexpr double kMinConditioning = 1e-3;

uint8_t LambertSubset(const TexelSamples& t, const std::vector<Vec3>& dirs, FitResult* r) {
  if (t.valid_count < 3) return kTexelTooFewLights;
  const int C = t.channels;
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b[3] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                          Eigen::Vector3d::Zero()};
  for (int i = 0; i < t.n; ++i) {
    if (!t.valid[i]) continue;
    const Eigen::Vector3d l(dirs[i].x, dirs[i].y, dirs[i].z);
    M += l * l.transpose();
    for (int c = 0; c < C; ++c) b[c] += l * t.obs[i * C + c];
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(M, Eigen::EigenvaluesOnly);
  const auto ev = eig.eigenvalues();  // ascending
  if (!(ev[2] > 0 && ev[0] >= kMinConditioning * ev[2])) return kTexelIllConditioned;
  const auto ldlt = M.ldlt();
  Eigen::Vector3d g[3], lum = Eigen::Vector3d::Zero();
  for (int c = 0; c < C; ++c) {
    g[c] = ldlt.solve(b[c]);
    lum += g[c] * (C == 1 ? 1.0 : double(kLuma[c]));
  }
  const double len = lum.norm();
  if (!std::isfinite(len)) return kTexelNonFinite;
  if (!(len > 1e-6)) return kTexelNoSignal;
  const Eigen::Vector3d u = lum / len, Mu = M * u;
  const double inv_den = 1.0 / u.dot(Mu);
  for (int c = 0; c < 3; ++c) {
    r->maps.normal.Plane(c)[t.p] = float(u[c]);
    r->maps.albedo.Plane(c)[t.p] = float(Mu.dot(g[C == 1 ? 0 : c]) * inv_den);
  }
  return kTexelOk;
}

}  // namespace

StatusOr<FitResult> FitLambert(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  auto lm = MakeLightMatrix(s.lights());
  if (!lm.ok()) return Status(lm.status().code(), "lambert: " + lm.status().message());
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, "lambert", "lambert", &r);
  r.parameters["light_condition_number"] = lm->condition;
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  double M[9] = {};  // LᵀL
  for (const auto& l : s.lights())
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) M[a * 3 + b] += l.direction[a] * l.direction[b];
  const bool clip = StackMayBeClipped(s);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int64_t first = int64_t(t.y0) * W, m = t.texels();
    std::vector<float> g(size_t(3) * C * m, 0.0f), peak(m, 0.0f);  // [c][x, y, z][m]
    StripReader reader(s);
    float w[kMaxRowPlanes * 3];
    for (int c = 0; c < C; ++c) {
      float* gc[3] = {&g[(3 * c) * m], &g[(3 * c + 1) * m], &g[(3 * c + 2) * m]};
      for (int i0 = 0; i0 < n; i0 += kMaxRowPlanes) {
        const int planes = std::min(kMaxRowPlanes, n - i0);
        for (int q = 0; q < planes; ++q) {
          const int i = i0 + q;
          for (int j = 0; j < 3; ++j)
            w[q * 3 + j] = float(lm->pinv[size_t(j) * n + i]) * inv[i * C + c];
        }
        reader.Group(i0, planes, c, first, m, [&](const float* const* src, int64_t x, int64_t len) {
          float* a[3] = {gc[0] + x, gc[1] + x, gc[2] + x};
          RowAccumulate(src, planes, len, 3, w, a, peak.data() + x);
        });
      }
    }
    ApplyPeakStatus(peak.data(), first, m, clip, r.status.data());
    for (int64_t k = 0; k < m; ++k) {
      const int64_t p = first + k;
      if (r.status[p] != kTexelOk) continue;  // masked or flagged
      Vec3 gch[3], lum;
      for (int c = 0; c < C; ++c) {
        gch[c] = Vec3(g[(3 * c) * m + k], g[(3 * c + 1) * m + k], g[(3 * c + 2) * m + k]);
        lum += gch[c] * (C == 1 ? 1.0 : double(kLuma[c]));
      }
      const double len = Length(lum);
      if (!IsFinite(lum)) {
        r.status[p] = kTexelNonFinite;
        continue;
      }
      if (!(len > 1e-6)) {
        r.status[p] = kTexelNoSignal;
        continue;
      }
      const Vec3 u = lum * (1.0 / len);
      const Vec3 Mu(M[0] * u.x + M[1] * u.y + M[2] * u.z, M[3] * u.x + M[4] * u.y + M[5] * u.z,
                    M[6] * u.x + M[7] * u.y + M[8] * u.z);
      const double inv_den = 1.0 / Dot(u, Mu);  // Σ_i (n·l_i)² > 0 for non-coplanar lights
      for (int c = 0; c < 3; ++c) {
        r.maps.normal.Plane(c)[p] = float(u[c]);
        r.maps.albedo.Plane(c)[p] = float(Dot(Mu, gch[C == 1 ? 0 : c]) * inv_den);
      }
    }
  });
  if (ok) {
    std::vector<Vec3> dirs(n);
    for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
    RefitFromValidSamples(
        s, {}, [&](const TexelSamples& t, FitResult* out) { return LambertSubset(t, dirs, out); },
        &r);
  }
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
