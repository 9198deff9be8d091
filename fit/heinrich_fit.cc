// `heinrich` (seed method A, METHODS.md §2), fast form.
//
// Per texel the 6-unknown normal equations share their structure across texels: with
// t_c the mean texture, q_c = Σ_i p_ci l_i, S = Σ_i l_i, m = S/N, M = Σ_i l_i l_iᵀ,
// eliminating the ambient gives a_c = 1 − m·n (grey) and
//   (M − N m mᵀ) n = Σ_c t_c q_c / Σ_c t_c² − S = Σ_c t_c q'_c / Σ_c t_c²,
// with q'_c = Σ_i p_ci (l_i − m) = q_c − N m t_c, so one 3 × 3 inverse serves every texel and
// a fit costs one pass over the planes. Accumulating the centred q'_c directly avoids the
// cancellation against S, which is what lets the sums run in float (two-level, row_kernels.h)
// and still agree with the double-precision reference to 1e-6.
// A texel with a clipped or non-finite sample is fitted again from its valid lights V alone
// (fit/valid_refit.h) with the reference's per-texel 6 × 6 normal equations over V.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/gauss_jordan.h"
#include "fit/heinrich_specular.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "fit/valid_refit.h"

namespace matfit::fit {

namespace {

// K = (Σ_i (l_i − m)(l_i − m)ᵀ)⁻¹; fails when the lights have no spread in some direction
// (e.g. a ring at one elevation: n_z and the ambient are then inseparable).
StatusOr<Eigen::Matrix3d> ScatterInverse(const LightStack& s, Vec3* sum) {
  const int n = s.num_images();
  Eigen::Vector3d S = Eigen::Vector3d::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const auto& l : s.lights()) {
    const Eigen::Vector3d d(l.direction.x, l.direction.y, l.direction.z);
    S += d;
    M += d * d.transpose();
  }
  const Eigen::Vector3d m = S / n;
  const Eigen::Matrix3d scatter = M - n * m * m.transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(scatter);
  const auto sv = svd.singularValues();
  if (n < 4 || !(sv[2] > 1e-9 * std::max(1.0, sv[0])))
    return InvalidArgument(
        "heinrich: the light directions do not spread in all three axes "
        "around their mean (e.g. every light at one elevation), so the normal's "
        "z and the ambient term are inseparable; use lights at several θ "
        "(such as the Bonn 81-light set) or the lambert model");
  *sum = {S.x(), S.y(), S.z()};
  return Eigen::Matrix3d(scatter.inverse());
}

// The seed's per-texel system (heinrich_reference.cc) over the valid lights V: t_c the mean
// of p_c / I_c over V, rows (t_c l, e_c) · (n_raw, a) = p_ic / I_ic. V must spread in all three
// axes around its mean (λ_min / λ_max of the scatter ≥ 1e-3), or n_z and the ambient mix.
uint8_t HeinrichSubset(const TexelSamples& t, const std::vector<Vec3>& dirs, MaterialMaps* maps) {
  const int C = t.channels, V = t.valid_count;
  if (V < 4) return kTexelTooFewLights;
  Eigen::Vector3d S = Eigen::Vector3d::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  double tc[3] = {0, 0, 0};
  for (int i = 0; i < t.n; ++i) {
    if (!t.valid[i]) continue;
    const Eigen::Vector3d l(dirs[i].x, dirs[i].y, dirs[i].z);
    S += l, M += l * l.transpose();
    for (int c = 0; c < C; ++c) tc[c] += t.obs[i * C + c] / V;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(M - S * S.transpose() / V, Eigen::EigenvaluesOnly);
  const auto ev = eig.eigenvalues();  // ascending
  if (!(ev[2] > 0 && ev[0] >= 1e-3 * ev[2])) return kTexelIllConditioned;
  if (!(tc[0] * tc[0] + tc[1] * tc[1] + tc[2] * tc[2] > 1e-12)) return kTexelNoSignal;
  double ata[36] = {}, atb[6] = {};
  for (int i = 0; i < t.n; ++i) {
    if (!t.valid[i]) continue;
    const Vec3& l = dirs[i];
    for (int c = 0; c < C; ++c) {
      double row[6] = {tc[c] * l.x, tc[c] * l.y, tc[c] * l.z, 0, 0, 0};
      row[3 + c] = tc[c];
      const double b = t.obs[i * C + c];
      for (int j = 0; j < 6; ++j) {
        atb[j] += row[j] * b;
        for (int k = 0; k < 6; ++k) ata[j * 6 + k] += row[j] * row[k];
      }
    }
  }
  if (C == 1) ata[4 * 6 + 4] = ata[5 * 6 + 5] = 1;  // unused g, b ambients: identity rows
  if (!GaussJordanInvert<6>(ata)) return kTexelIllConditioned;
  double xs[6] = {};
  for (int j = 0; j < 6; ++j)
    for (int k = 0; k < 6; ++k) xs[j] += ata[j * 6 + k] * atb[k];
  if (!std::isfinite(xs[0] + xs[1] + xs[2] + xs[3] + xs[4] + xs[5])) return kTexelNonFinite;
  StoreHeinrichTexel(maps, t.p, C, tc, xs + 3, Vec3(xs[0], xs[1], xs[2]));
  return kTexelOk;
}

}  // namespace

StatusOr<FitResult> FitHeinrich(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  Vec3 S;
  auto K = ScatterInverse(s, &S);
  if (!K.ok()) return K.status();
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitHeinrichResult(s, "heinrich", &r);
  MaterialMaps& maps = r.maps;
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const Vec3 mean = S / double(n);
  std::vector<Vec3> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
  const Eigen::Matrix3d k3 = *K;

  const bool clip = StackMayBeClipped(s);
  // Per strip (one contiguous segment of every plane): accumulate t_c and q′_c image by image
  // with the row kernel, then solve each texel of the strip.
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int64_t first = int64_t(t.y0) * W, m = t.texels();
    std::vector<float> acc(size_t(12) * m, 0.0f);  // [c][t, q′x, q′y, q′z][m]
    std::vector<float> peak(m, 0.0f);
    StripReader reader(s);
    float w[kMaxRowPlanes * 4];
    for (int c = 0; c < C; ++c) {
      float* a = acc.data() + size_t(4 * c) * m;
      float* ap[4] = {a, a + m, a + 2 * m, a + 3 * m};
      for (int i0 = 0; i0 < n; i0 += kMaxRowPlanes) {
        const int planes = std::min(kMaxRowPlanes, n - i0);
        for (int q = 0; q < planes; ++q) {
          const int i = i0 + q;
          const double wi = inv[i * C + c];
          w[q * 4] = float(wi), w[q * 4 + 1] = float((dirs[i].x - mean.x) * wi);
          w[q * 4 + 2] = float((dirs[i].y - mean.y) * wi),
                    w[q * 4 + 3] = float((dirs[i].z - mean.z) * wi);
        }
        reader.Group(i0, planes, c, first, m, [&](const float* const* src, int64_t x, int64_t len) {
          float* a4[4] = {ap[0] + x, ap[1] + x, ap[2] + x, ap[3] + x};
          RowAccumulate(src, planes, len, 4, w, a4, peak.data() + x);
        });
      }
    }
    ApplyPeakStatus(peak.data(), first, m, clip, r.status.data());
    float *albedo[3], *ambient[3], *normal[3];
    for (int c = 0; c < 3; ++c) {
      albedo[c] = maps.albedo.Plane(c).data() + first;
      ambient[c] = maps.ambient.Plane(c).data() + first;
      normal[c] = maps.normal.Plane(c).data() + first;
    }
    float* scale = maps.normal_scale.Plane(0).data() + first;
    uint8_t* status = r.status.data() + first;
    // Two divisions per texel (1/t2, 1/|n_raw|): the solve is about a third of the fit's time.
    const double inv_n = 1.0 / n;
    for (int64_t k = 0; k < m; ++k) {
      if (status[k] != kTexelOk) continue;  // masked or flagged
      double tc[3] = {0, 0, 0}, t2 = 0, u[3] = {0, 0, 0};
      for (int c = 0; c < C; ++c) {
        const float* a = acc.data() + size_t(4 * c) * m + k;
        tc[c] = a[0] * inv_n;
        t2 += tc[c] * tc[c];
        for (int j = 0; j < 3; ++j) u[j] += a[(j + 1) * m] * tc[c];
      }
      if (!std::isfinite(t2 + u[0] + u[1] + u[2])) {
        status[k] = kTexelNonFinite;
        continue;
      }
      if (!(t2 > 1e-12)) {
        status[k] = kTexelNoSignal;
        continue;
      }
      const double inv_t2 = 1.0 / t2;
      for (int j = 0; j < 3; ++j) u[j] *= inv_t2;
      double nr[3], len2 = 0;  // n_raw = K u
      for (int j = 0; j < 3; ++j) {
        nr[j] = k3(j, 0) * u[0] + k3(j, 1) * u[1] + k3(j, 2) * u[2];
        len2 += nr[j] * nr[j];
      }
      const double a = 1.0 - (mean.x * nr[0] + mean.y * nr[1] + mean.z * nr[2]);  // grey ambient
      const double len = std::sqrt(len2), inv_len = len > 0 ? 1.0 / len : 0.0;
      for (int c = 0; c < 3; ++c) {
        albedo[c][k] = float(tc[C == 1 ? 0 : c]);
        ambient[c][k] = float(a);
        normal[c][k] = len > 0 ? float(nr[c] * inv_len) : float(c == 2);
      }
      scale[k] = float(len);
    }
  });
  if (ok)
    RefitFromValidSamples(
        s, {},
        [&](const TexelSamples& t, FitResult* out) { return HeinrichSubset(t, dirs, &out->maps); },
        &r);
  if (ok && o.heinrich_specular) AddHeinrichSpecular(s, o, &r);
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
