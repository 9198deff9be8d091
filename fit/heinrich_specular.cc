#include "fit/heinrich_specular.h"

#include "core/stack_band.h"

#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include "core/parallel.h"
#include "core/shading/evaluate.h"
#include "core/warnings.h"
#include "fit/fit_common.h"
#include "fit/light_matrix.h"

namespace matfit::fit {

void StoreHeinrichTexel(MaterialMaps* maps, int64_t p, int C, const double t[3],
                        const double ambient[3], const Vec3& n_raw) {
  const double len = Length(n_raw);
  const Vec3 unit = len > 0 ? n_raw / len : Vec3(0, 0, 1);
  for (int c = 0; c < 3; ++c) {
    maps->albedo.Plane(c)[p] = float(t[C == 1 ? 0 : c]);
    maps->ambient.Plane(c)[p] = float(ambient[C == 1 ? 0 : c]);
    maps->normal.Plane(c)[p] = float(unit[c]);
  }
  maps->normal_scale.Plane(0)[p] = float(len);
}

double HeinrichSquaredError(const LightStack& s, const FitResult& r, int64_t* samples) {
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width(), H = s.height();
  const Vec3f v(s.view_direction);
  std::vector<Vec3f> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = Vec3f(s.lights()[i].direction);
  const float clip_level =
      StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  std::mutex mu;
  double total = 0;
  int64_t count = 0;
  ParallelFor(0, H, [&](int64_t y0, int64_t y1) {
    double local = 0;
    int64_t local_count = 0;
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        const int64_t p = y * W + x;
        if (r.status[p] != kTexelOk) continue;
        for (int i = 0; i < n; ++i)
          for (int c = 0; c < C; ++c) {
            // Clipped and non-finite samples (dropped by the fit, fit/valid_refit.h) do not count.
            const float raw = s.Sample(i, c, p);
            if (!(std::isfinite(raw) && raw < clip_level)) continue;
            const double d = raw * inv[i * C + c] - EvaluateTexel(r.maps, p, c, dirs[i], v);
            local += d * d;
            ++local_count;
          }
      }
    std::lock_guard<std::mutex> lock(mu);
    total += local;
    count += local_count;
  });
  double sums[2] = {total, double(count)};  // a band of a distributed stack: every band's
  SumOverBands(s, sums, 2);
  if (samples) *samples = int64_t(sums[1]);
  return sums[0];
}

void AddHeinrichSpecular(const LightStack& s, const FitOptions& o, FitResult* r) {
  const int i1 = FindLightAlong(s.lights(), s.view_direction, 1.0);
  if (i1 < 0) {
    r->warnings.push_back(
        Warning(WarningCode::kNoViewAlignedLight,
                "no image has its light along the view direction (θl = θv): the seed "
                "specular map needs one; fitted diffuse + ambient only"));
    return;
  }
  const int C = s.channels(), W = s.width(), H = s.height();
  const std::vector<float> inv = InverseIntensities(s);
  MaterialMaps& m = r->maps;
  m.specular_flat_normal = o.heinrich_flat_specular_normal;
  m.specular_color = Image(W, H, 3);
  m.exponent = Image(W, H, 1, 1.0f);
  const Vec3f l1(s.lights()[i1].direction), v(s.view_direction);
  // L_spec,c = p_{c,#1} − diffuse reconstruction at #1 (evaluated before the map exists).
  for (int64_t p = 0; p < s.plane_size(); ++p) {
    if (r->status[p] != kTexelOk) continue;
    for (int c = 0; c < 3; ++c) {
      const int sc = C == 1 ? 0 : c;
      // A non-finite sample #1 carries no specular information (a clipped one is a lower bound,
      // kept).
      const float raw = s.Sample(i1, sc, p);
      m.specular_color.Plane(c)[p] =
          std::isfinite(raw) ? raw * inv[i1 * C + sc] - EvaluateTexel(m, p, c, l1, v) : 0.0f;
    }
  }
  // One exponent per material: coarse search over powers of two, then golden section in log2 e.
  auto deviation = [&](double e) {
    std::fill(m.exponent.data().begin(), m.exponent.data().end(), float(e));
    return HeinrichSquaredError(s, *r, nullptr);
  };
  const double lo = std::log2(o.exponent_min), hi = std::log2(o.exponent_max);
  double best_k = lo, best = deviation(std::exp2(lo));
  for (double k = std::ceil(lo); k <= hi; k += 1) {
    const double d = deviation(std::exp2(k));
    if (d < best) best = d, best_k = k;
  }
  double a = std::max(lo, best_k - 1), b = std::min(hi, best_k + 1);
  const double phi = (std::sqrt(5.0) - 1) / 2;
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
  double f1 = deviation(std::exp2(x1)), f2 = deviation(std::exp2(x2));
  for (int it = 0; it < 24; ++it) {
    if (f1 < f2)
      b = x2, x2 = x1, f2 = f1, x1 = b - phi * (b - a), f1 = deviation(std::exp2(x1));
    else
      a = x1, x1 = x2, f1 = f2, x2 = a + phi * (b - a), f2 = deviation(std::exp2(x2));
  }
  double e = std::exp2(f1 < f2 ? x1 : x2);
  if (std::min(f1, f2) > best) e = std::exp2(best_k);
  deviation(e);
  r->parameters["exponent"] = e;
  r->parameters["specular_sample"] = i1;
}

}  // namespace matfit::fit
