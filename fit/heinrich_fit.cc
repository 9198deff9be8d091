// `heinrich` (seed method A, METHODS.md §2), fast form.
//
// Per texel the 6-unknown normal equations share their structure across texels: with
// t_c the mean texture, q_c = Σ_i p_ci l_i, S = Σ_i l_i, m = S/N, M = Σ_i l_i l_iᵀ,
// eliminating the ambient gives a_c = 1 − m·n (grey) and
//   (M − N m mᵀ) n = Σ_c t_c q_c / Σ_c t_c² − S,
// so one 3 × 3 inverse serves every texel and a fit costs one pass over the planes.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/heinrich_specular.h"
#include "fit/methods.h"

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

}  // namespace

StatusOr<FitResult> FitHeinrich(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  Vec3 S;
  auto K = ScatterInverse(s, &S);
  if (!K.ok()) return K.status();
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kHeinrich, "heinrich", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  MaterialMaps& maps = r.maps;
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const Vec3 mean = S / double(n);
  std::vector<Vec3> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
  const Eigen::Matrix3d k3 = *K;

  // One row segment of a tile at a time: accumulate t_c and q_c image by image (streaming
  // contiguous plane rows, vectorisable), then solve each texel of the segment.
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int tw = t.width;
    std::vector<double> acc(size_t(12) * tw);  // [c][0..3] × tw: t_c, q_c.x, q_c.y, q_c.z
    for (int y = t.y0; y < t.y0 + t.height; ++y) {
      std::fill(acc.begin(), acc.end(), 0.0);
      const int64_t row = int64_t(y) * W + t.x0;
      for (int i = 0; i < n; ++i) {
        const double lx = dirs[i].x, ly = dirs[i].y, lz = dirs[i].z;
        for (int c = 0; c < C; ++c) {
          const float* src = s.Plane(i, c).data() + row;
          const double w = inv[i * C + c];
          double* at = acc.data() + size_t(4 * c) * tw;
          double *ax = at + tw, *ay = at + 2 * tw, *az = at + 3 * tw;
          for (int k = 0; k < tw; ++k) {
            const double v = src[k] * w;
            at[k] += v, ax[k] += lx * v, ay[k] += ly * v, az[k] += lz * v;
          }
        }
      }
      for (int k = 0; k < tw; ++k) {
        const int64_t p = row + k;
        if (r.status[p] != kTexelOk) continue;  // masked or flagged before fitting
        double tc[3] = {0, 0, 0}, t2 = 0;
        Vec3 u;
        for (int c = 0; c < C; ++c) {
          const double* at = acc.data() + size_t(4 * c) * tw;
          tc[c] = at[k] / n;
          t2 += tc[c] * tc[c];
          u += Vec3(at[tw + k], at[2 * tw + k], at[3 * tw + k]) * tc[c];
        }
        if (!std::isfinite(t2) || !IsFinite(u)) {
          r.status[p] = kTexelNonFinite;
          continue;
        }
        if (!(t2 > 1e-12)) {
          r.status[p] = kTexelNoSignal;
          continue;
        }
        u = u / t2 - S;
        const Eigen::Vector3d nn = k3 * Eigen::Vector3d(u.x, u.y, u.z);
        const Vec3 nraw(nn.x(), nn.y(), nn.z());
        const double a = 1.0 - Dot(mean, nraw);  // grey ambient
        const double ambient[3] = {a, a, a};
        StoreHeinrichTexel(&maps, p, C, tc, ambient, nraw);
      }
    }
  });
  if (ok && o.heinrich_specular) AddHeinrichSpecular(s, o, &r);
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
