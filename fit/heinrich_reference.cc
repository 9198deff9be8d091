// `heinrich` reference: the seed's literal per-texel solve. For each texel build the 3N × 6
// system row by row, form AᵀA and Aᵀb, invert the 6 × 6 by Gauss–Jordan (partial pivoting).
#include <chrono>
#include <cmath>
#include <utility>

#include "fit/fit_common.h"
#include "fit/heinrich_specular.h"
#include "fit/methods.h"

namespace matfit::fit {

namespace {

// Inverts a (6 × 6, row-major) in place; false when a pivot vanishes.
bool GaussJordanInvert6(double a[36]) {
  double inv[36] = {};
  for (int i = 0; i < 6; ++i) inv[i * 6 + i] = 1;
  for (int col = 0; col < 6; ++col) {
    int piv = col;
    for (int r = col + 1; r < 6; ++r)
      if (std::abs(a[r * 6 + col]) > std::abs(a[piv * 6 + col])) piv = r;
    if (!(std::abs(a[piv * 6 + col]) > 1e-12)) return false;
    if (piv != col)
      for (int k = 0; k < 6; ++k)
        std::swap(a[col * 6 + k], a[piv * 6 + k]), std::swap(inv[col * 6 + k], inv[piv * 6 + k]);
    const double d = 1.0 / a[col * 6 + col];
    for (int k = 0; k < 6; ++k) a[col * 6 + k] *= d, inv[col * 6 + k] *= d;
    for (int r = 0; r < 6; ++r) {
      if (r == col) continue;
      const double f = a[r * 6 + col];
      if (f == 0) continue;
      for (int k = 0; k < 6; ++k)
        a[r * 6 + k] -= f * a[col * 6 + k], inv[r * 6 + k] -= f * inv[col * 6 + k];
    }
  }
  std::copy(inv, inv + 36, a);
  return true;
}

}  // namespace

StatusOr<FitResult> FitHeinrichReference(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kHeinrich, "heinrich-reference", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  MaterialMaps& maps = r.maps;
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    for (int y = t.y0; y < t.y0 + t.height; ++y)
      for (int x = t.x0; x < t.x0 + t.width; ++x) {
        const int64_t p = int64_t(y) * W + x;
        if (r.status[p] != kTexelOk) continue;  // masked or flagged before fitting
        double tc[3] = {0, 0, 0};
        for (int i = 0; i < n; ++i)
          for (int c = 0; c < C; ++c) tc[c] += double(s.Plane(i, c)[p]) * inv[i * C + c] / n;
        double ata[36] = {}, atb[6] = {};
        for (int i = 0; i < n; ++i) {
          const Vec3& l = s.lights()[i].direction;
          for (int c = 0; c < C; ++c) {
            double row[6] = {tc[c] * l.x, tc[c] * l.y, tc[c] * l.z, 0, 0, 0};
            row[3 + c] = tc[c];
            const double b = double(s.Plane(i, c)[p]) * inv[i * C + c];
            for (int j = 0; j < 6; ++j) {
              atb[j] += row[j] * b;
              for (int k = 0; k < 6; ++k) ata[j * 6 + k] += row[j] * row[k];
            }
          }
        }
        if (C == 1) ata[4 * 6 + 4] = ata[5 * 6 + 5] = 1;  // unused g, b ambients: identity rows
        if (!std::isfinite(atb[0] + atb[1] + atb[2] + atb[3])) {
          r.status[p] = kTexelNonFinite;
          continue;
        }
        if (!(tc[0] * tc[0] + tc[1] * tc[1] + tc[2] * tc[2] > 1e-12)) {
          r.status[p] = kTexelNoSignal;
          continue;
        }
        if (!GaussJordanInvert6(ata)) {
          r.status[p] = kTexelIllConditioned;
          continue;
        }
        double xs[6] = {};
        for (int j = 0; j < 6; ++j)
          for (int k = 0; k < 6; ++k) xs[j] += ata[j * 6 + k] * atb[k];
        StoreHeinrichTexel(&maps, p, C, tc, xs + 3, Vec3(xs[0], xs[1], xs[2]));
      }
  });
  if (ok && o.heinrich_specular) AddHeinrichSpecular(s, o, &r);
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
