// `mean`: per-texel mean colour over all images (the seed's "diffuse texture" t_c).
#include <chrono>
#include <cmath>

#include "fit/fit_common.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitMean(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kMean, "mean", &r);
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    for (int y = t.y0; y < t.y0 + t.height; ++y)
      for (int x = t.x0; x < t.x0 + t.width; ++x) {
        const int64_t p = int64_t(y) * W + x;
        if (r.status[p] == kTexelMasked) continue;
        for (int c = 0; c < C; ++c) {
          double sum = 0;
          for (int i = 0; i < n; ++i) sum += s.Plane(i, c)[p] * inv[i * C + c];
          const float mean = float(sum / n);
          if (!std::isfinite(mean)) r.status[p] = kTexelNonFinite;
          for (int k = (C == 1 ? 0 : c); k < (C == 1 ? 3 : c + 1); ++k)
            r.maps.albedo.Plane(k)[p] = std::isfinite(mean) ? mean : 0.0f;
        }
        r.maps.normal.Plane(2)[p] = 1.0f;
      }
  });
  if (!ok) return Status(StatusCode::kCancelled, "fit cancelled");
  SummariseStatus(&r);
  r.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace matfit::fit
