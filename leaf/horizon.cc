#include "leaf/horizon.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/check.h"
#include "core/parallel.h"

namespace matfit::leaf {
namespace {

float Bilinear(const Image& img, double x, double y) {
  const int w = img.width(), h = img.height();
  x = std::clamp(x, 0.0, double(w - 1)), y = std::clamp(y, 0.0, double(h - 1));
  const int x0 = std::min(int(x), std::max(w - 2, 0)), y0 = std::min(int(y), std::max(h - 2, 0));
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const double fx = x - x0, fy = y - y0;
  const auto p = img.Plane(0);
  const double top = p[int64_t(y0) * w + x0] * (1 - fx) + p[int64_t(y0) * w + x1] * fx;
  const double bot = p[int64_t(y1) * w + x0] * (1 - fx) + p[int64_t(y1) * w + x1] * fx;
  return float(top * (1 - fy) + bot * fy);
}

}  // namespace

Image HorizonMap(const Image& height, double mm_per_texel, int row_of_y, const HorizonOptions& o) {
  MATFIT_CHECK(height.channels() == 1 && mm_per_texel > 0 && o.slices >= 4);
  const int w = height.width(), h = height.height();
  Image out(w, h, o.slices);
  std::vector<int> steps;
  for (int s = 1; s <= o.max_steps; s = std::max(s + 1, s * 4 / 3)) steps.push_back(s);
  ParallelFor(
      0, h,
      [&](int64_t y0, int64_t y1) {
        for (int k = 0; k < o.slices; ++k) {
          const double phi = 2 * std::numbers::pi * k / o.slices;
          const double dx = std::cos(phi), dy = std::sin(phi) * row_of_y;
          auto plane = out.Plane(k);
          for (int64_t y = y0; y < y1; ++y)
            for (int x = 0; x < w; ++x) {
              const double h0 = height.At(0, int(y), x);
              double best = -1e30;
              for (int s : steps) {
                const double sx = x + s * dx, sy = y + s * dy;
                if (sx < 0 || sy < 0 || sx > w - 1 || sy > h - 1) break;
                best = std::max(best, (Bilinear(height, sx, sy) - h0) / (s * mm_per_texel));
              }
              plane[y * w + x] = float(std::atan(best));  // elevation angle, rad
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
