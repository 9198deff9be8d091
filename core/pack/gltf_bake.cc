#include "core/pack/gltf_bake.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/model/model.h"
#include "core/parallel.h"

namespace matfit {

void LambertianBake(const MaterialMaps& m, Image* base, Image* normal) {
  // Rings at θ = 0, 15, 30, 45, 60° with 1, 6, 12, 12, 6 azimuths: 37 directions.
  std::vector<Vec3f> dirs;
  const int per_ring[] = {1, 6, 12, 12, 6};
  for (int r = 0; r < 5; ++r)
    for (int k = 0; k < per_ring[r]; ++k) {
      const double t = r * 15 * std::numbers::pi / 180, p = 2 * std::numbers::pi * k / per_ring[r];
      dirs.push_back(Vec3f(float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)),
                           float(std::cos(t))));
    }
  const int K = int(dirs.size()), ch = m.albedo.channels() == 3 ? 3 : 1;
  // (Σ l lᵀ)⁻¹, the same for every texel.
  double a[3][3] = {};
  for (const Vec3f& l : dirs)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] += double((&l.x)[i]) * double((&l.x)[j]);
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  double inv[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      inv[i][j] = (a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]) / det;
    }
  *base = Image(m.width, m.height, 3);
  *normal = Image(m.width, m.height, 3);
  const BatchEvaluator eval(m, dirs, Vec3f(0, 0, 1));
  const int64_t n = int64_t(m.width) * m.height;
  constexpr int kRun = 256;
  ParallelFor(0, (n + kRun - 1) / kRun, [&](int64_t r0, int64_t r1) {
    std::vector<float> out(size_t(K) * ch * kRun);
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kRun;
      const int len = int(std::min<int64_t>(kRun, n - p0));
      for (int k = 0; k < K; ++k) eval.Evaluate(k, p0, len, ch, out.data() + size_t(k) * ch * len);
      auto value = [&](int k, int c, int t) { return double(out[(size_t(k) * ch + c) * len + t]); };
      for (int t = 0; t < len; ++t) {
        double b[3] = {0, 0, 0};
        for (int k = 0; k < K; ++k) {
          const double y =
              ch == 3 ? 0.2126 * value(k, 0, t) + 0.7152 * value(k, 1, t) + 0.0722 * value(k, 2, t)
                      : value(k, 0, t);
          for (int i = 0; i < 3; ++i) b[i] += y * double((&dirs[size_t(k)].x)[i]);
        }
        Vec3 g{inv[0][0] * b[0] + inv[0][1] * b[1] + inv[0][2] * b[2],
               inv[1][0] * b[0] + inv[1][1] * b[1] + inv[1][2] * b[2],
               inv[2][0] * b[0] + inv[2][1] * b[1] + inv[2][2] * b[2]};
        const double len_g = std::sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
        Vec3 nn = len_g > 1e-9 ? Vec3{g.x / len_g, g.y / len_g, g.z / len_g} : Vec3{0, 0, 1};
        if (nn.z < 0) nn = {-nn.x, -nn.y, -nn.z};
        const int64_t p = p0 + t;
        normal->Plane(0)[p] = float(nn.x), normal->Plane(1)[p] = float(nn.y),
        normal->Plane(2)[p] = float(nn.z);
        for (int c = 0; c < 3; ++c) {
          double num = 0, den = 0;
          for (int k = 0; k < K; ++k) {
            const Vec3f& l = dirs[size_t(k)];
            const double s = std::max(0.0, nn.x * l.x + nn.y * l.y + nn.z * l.z);
            num += value(k, std::min(c, ch - 1), t) * s, den += s * s;
          }
          base->Plane(c)[p] = float(std::clamp(den > 0 ? num / den : 0.0, 0.0, 1.0));
        }
      }
    }
  });
}

}  // namespace matfit
