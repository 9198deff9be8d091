// `mean`: per-texel mean colour over all images (the seed's "diffuse texture" t_c).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitMean(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kMean, "mean", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/false, &r);  // a clipped mean is still a mean
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    std::vector<double> sum(size_t(C) * t.width);
    for (int y = t.y0; y < t.y0 + t.height; ++y) {
      std::fill(sum.begin(), sum.end(), 0.0);
      const int64_t row = int64_t(y) * W + t.x0;
      for (int i = 0; i < n; ++i)
        for (int c = 0; c < C; ++c) {
          const float* src = s.Plane(i, c).data() + row;
          const double w = inv[i * C + c];
          double* acc = sum.data() + size_t(c) * t.width;
          for (int k = 0; k < t.width; ++k) acc[k] += src[k] * w;
        }
      for (int k = 0; k < t.width; ++k) {
        const int64_t p = row + k;
        if (r.status[p] != kTexelOk) continue;
        for (int c = 0; c < 3; ++c) {
          const float mean = float(sum[size_t(C == 1 ? 0 : c) * t.width + k] / n);
          if (!std::isfinite(mean)) r.status[p] = kTexelNonFinite;
          r.maps.albedo.Plane(c)[p] = std::isfinite(mean) ? mean : 0.0f;
        }
        r.maps.normal.Plane(2)[p] = 1.0f;
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
