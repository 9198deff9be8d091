// `lambert`: classic photometric stereo with one precomputed pseudo-inverse.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/light_matrix.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitLambert(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  auto lm = MakeLightMatrix(s.lights());
  if (!lm.ok()) return Status(lm.status().code(), "lambert: " + lm.status().message());
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kLambert, "lambert", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  r.parameters["light_condition_number"] = lm->condition;
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  std::vector<float> pinv(lm->pinv.begin(), lm->pinv.end());
  std::vector<Vec3f> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = Vec3f(s.lights()[i].direction);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int tw = t.width;
    const int64_t m = t.texels();
    std::vector<float> gx(m, 0.0f), gy(m, 0.0f), gz(m, 0.0f), y(m);
    // Pass 1: g = P · luminance, streaming one image plane row at a time.
    for (int i = 0; i < n; ++i) {
      const float px = pinv[i], py = pinv[n + i], pz = pinv[2 * n + i];
      for (int yy = 0; yy < t.height; ++yy) {
        const int64_t row = int64_t(t.y0 + yy) * W + t.x0;
        float* yl = y.data() + int64_t(yy) * tw;
        for (int xx = 0; xx < tw; ++xx) yl[xx] = 0.0f;
        for (int c = 0; c < C; ++c) {
          const float w = (C == 1 ? 1.0f : kLuma[c]) * inv[i * C + c];
          const float* src = s.Plane(i, c).data() + row;
          for (int xx = 0; xx < tw; ++xx) yl[xx] += w * src[xx];
        }
        for (int xx = 0; xx < tw; ++xx) {
          const int64_t k = int64_t(yy) * tw + xx;
          gx[k] += px * yl[xx], gy[k] += py * yl[xx], gz[k] += pz * yl[xx];
        }
      }
    }
    // Normal, then albedo per channel by 1-D least squares on s_i = max(0, n·l_i), again
    // image by image over contiguous rows.
    std::vector<float> num(size_t(3) * tw), den(tw);
    for (int yy = 0; yy < t.height; ++yy) {
      const int64_t row = int64_t(t.y0 + yy) * W + t.x0;
      float* nx = gx.data() + int64_t(yy) * tw;
      float* ny = gy.data() + int64_t(yy) * tw;
      float* nz = gz.data() + int64_t(yy) * tw;
      for (int xx = 0; xx < tw; ++xx) {
        const int64_t p = row + xx;
        const Vec3f g(nx[xx], ny[xx], nz[xx]);
        const float len = Length(g);
        if (r.status[p] != kTexelOk) continue;  // masked or flagged before fitting
        if (!IsFinite(g))
          r.status[p] = kTexelNonFinite;
        else if (!(len > 1e-6f))
          r.status[p] = kTexelNoSignal;
        const Vec3f u = r.status[p] == kTexelOk ? g / len : Vec3f(0, 0, 0);
        nx[xx] = u.x, ny[xx] = u.y, nz[xx] = u.z;
      }
      std::fill(num.begin(), num.end(), 0.0f);
      std::fill(den.begin(), den.end(), 0.0f);
      for (int i = 0; i < n; ++i) {
        const Vec3f l = dirs[i];
        for (int xx = 0; xx < tw; ++xx) {
          const float si = std::max(0.0f, nx[xx] * l.x + ny[xx] * l.y + nz[xx] * l.z);
          y[xx] = si;  // reuse as s_i for this row
          den[xx] += si * si;
        }
        for (int c = 0; c < C; ++c) {
          const float* src = s.Plane(i, c).data() + row;
          const float w = inv[i * C + c];
          float* acc = num.data() + size_t(c) * tw;
          for (int xx = 0; xx < tw; ++xx) acc[xx] += src[xx] * w * y[xx];
        }
      }
      for (int xx = 0; xx < tw; ++xx) {
        const int64_t p = row + xx;
        if (r.status[p] != kTexelOk) continue;
        if (!(den[xx] > 1e-8f)) {
          r.status[p] = kTexelTooFewLights;
          continue;
        }
        r.maps.normal.Plane(0)[p] = nx[xx], r.maps.normal.Plane(1)[p] = ny[xx];
        r.maps.normal.Plane(2)[p] = nz[xx];
        for (int c = 0; c < 3; ++c)
          r.maps.albedo.Plane(c)[p] = num[size_t(C == 1 ? 0 : c) * tw + xx] / den[xx];
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
