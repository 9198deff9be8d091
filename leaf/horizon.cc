#include "leaf/horizon.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/check.h"
#include "core/parallel.h"

namespace matfit::leaf {
Image HorizonMap(const Image& height, double mm_per_texel, int row_of_y, const HorizonOptions& o) {
  MATFIT_CHECK(height.channels() == 1 && mm_per_texel > 0 && o.slices >= 4);
  const int w = height.width(), h = height.height();
  Image out(w, h, o.slices);
  std::vector<int> steps;
  for (int s = 1; s <= o.max_steps; s = std::max(s + 1, s * 4 / 3)) steps.push_back(s);
  // Along a slice, step s lands at the same sub-texel offset from every texel: its integer
  // offset and bilinear weights are computed once per (slice, step).
  struct Step {
    double ox, oy;  // offset in texels (x: columns, y: rows)
    int ix, iy;     // floor of the offset
    float w00, w01, w10, w11;
    float inv_dist;  // 1 / horizontal distance, 1/mm
  };
  const auto hp = height.Plane(0);
  ParallelFor(
      0, h,
      [&](int64_t y0, int64_t y1) {
        std::vector<Step> st(steps.size());
        for (int k = 0; k < o.slices; ++k) {
          const double phi = 2 * std::numbers::pi * k / o.slices;
          const double dx = std::cos(phi), dy = std::sin(phi) * row_of_y;
          for (size_t j = 0; j < steps.size(); ++j) {
            Step& e = st[j];
            e.ox = steps[j] * dx, e.oy = steps[j] * dy;
            e.ix = int(std::floor(e.ox)), e.iy = int(std::floor(e.oy));
            const float fx = float(e.ox - e.ix), fy = float(e.oy - e.iy);
            e.w00 = (1 - fx) * (1 - fy), e.w01 = fx * (1 - fy), e.w10 = (1 - fx) * fy,
            e.w11 = fx * fy;
            e.inv_dist = float(1 / (steps[j] * mm_per_texel));
          }
          auto plane = out.Plane(k);
          for (int64_t y = y0; y < y1; ++y)
            for (int x = 0; x < w; ++x) {
              const float h0 = hp[y * w + x];
              float best = -1e30f;
              for (const Step& e : st) {
                const double sx = x + e.ox, sy = y + e.oy;
                if (sx < 0 || sy < 0 || sx > w - 1 || sy > h - 1) break;
                const int xa = x + e.ix, ya = int(y) + e.iy;
                const int xb = std::min(xa + 1, w - 1), yb = std::min(ya + 1, h - 1);
                const float v = e.w00 * hp[int64_t(ya) * w + xa] +
                                e.w01 * hp[int64_t(ya) * w + xb] +
                                e.w10 * hp[int64_t(yb) * w + xa] + e.w11 * hp[int64_t(yb) * w + xb];
                best = std::max(best, (v - h0) * e.inv_dist);
              }
              plane[y * w + x] = std::atan(best);  // elevation angle, rad
            }
        }
      },
      4);
  return out;
}

float Visibility(const Image& horizon, int64_t p, const Vec3& w) {
  if (horizon.empty() || w.z <= 0) return w.z > 0 ? 1.0f : 0.0f;
  const int s = horizon.channels();
  const double horiz = std::sqrt(w.x * w.x + w.y * w.y);
  if (horiz < 1e-9) return 1.0f;
  double phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * std::numbers::pi;
  const double f = phi / (2 * std::numbers::pi) * s;
  const int k0 = int(f) % s, k1 = (k0 + 1) % s;
  const double t = f - std::floor(f);
  const double elev_h = horizon.Plane(k0)[p] * (1 - t) + horizon.Plane(k1)[p] * t;
  return SoftVisibility(float(std::atan2(w.z, horiz)), float(elev_h));
}

}  // namespace matfit::leaf
