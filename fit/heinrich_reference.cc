// `heinrich` reference: the seed's literal per-texel solve. For each texel build the 3N × 6
// system row by row, form AᵀA and Aᵀb, invert the 6 × 6 by Gauss–Jordan (partial pivoting).
#include <chrono>
#include <cmath>

#include "fit/fit_common.h"
#include "fit/gauss_jordan.h"
#include "fit/heinrich_specular.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitHeinrichReference(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitHeinrichResult(s, "heinrich-reference", &r);
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
          for (int c = 0; c < C; ++c) tc[c] += double(s.Sample(i, c, p)) * inv[i * C + c] / n;
        double ata[36] = {}, atb[6] = {};
        for (int i = 0; i < n; ++i) {
          const Vec3& l = s.lights()[i].direction;
          for (int c = 0; c < C; ++c) {
            double row[6] = {tc[c] * l.x, tc[c] * l.y, tc[c] * l.z, 0, 0, 0};
            row[3 + c] = tc[c];
            const double b = double(s.Sample(i, c, p)) * inv[i * C + c];
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
        if (!GaussJordanInvert<6>(ata)) {
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
