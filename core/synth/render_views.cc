#include "core/synth/render_views.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/model/model.h"
#include "core/parallel.h"

namespace matfit::synth {
namespace {

// Bilinear weights at (col, row), clamped to the frame (the sample does not continue outside).
struct Tap {
  int64_t p00, p01, p10, p11;
  float w00, w01, w10, w11;
};
Tap TapAt(int w, int h, double col, double row) {
  col = std::clamp(col, 0.0, double(w - 1));
  row = std::clamp(row, 0.0, double(h - 1));
  const int x0 = std::min(int(col), std::max(w - 2, 0)),
            y0 = std::min(int(row), std::max(h - 2, 0));
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const float fx = float(col - x0), fy = float(row - y0);
  return {int64_t(y0) * w + x0, int64_t(y0) * w + x1, int64_t(y1) * w + x0, int64_t(y1) * w + x1,
          (1 - fx) * (1 - fy),  fx * (1 - fy),        (1 - fx) * fy,        fx * fy};
}
float Sample(const float* plane, const Tap& t) {
  return plane[t.p00] * t.w00 + plane[t.p01] * t.w01 + plane[t.p10] * t.w10 + plane[t.p11] * t.w11;
}
double HeightAt(const Image& h, double col, double row) {
  return Sample(h.Plane(0).data(), TapAt(h.width(), h.height(), col, row));
}

// Every plane of `src` (when present) resampled at the taps.
void Resample(const Image& src, const std::vector<Tap>& taps, Image* dst) {
  if (src.empty()) return;
  *dst = Image(src.width(), src.height(), src.channels());
  for (int c = 0; c < src.channels(); ++c) {
    const float* in = src.Plane(c).data();
    float* out = dst->Plane(c).data();
    for (size_t p = 0; p < taps.size(); ++p) out[p] = Sample(in, taps[p]);
  }
}

}  // namespace

bool PointSeesLight(const Image& h, float hmax, double col, double row, double z, const Vec3& l) {
  if (l.z <= 0) return false;  // below the horizon
  const double horiz = std::hypot(l.x, l.y);
  if (horiz < 1e-9) return true;  // overhead: nothing rises above the ray
  // Image step per unit horizontal distance; y up means rows decrease toward +y.
  const double sx = l.x / horiz, sy = -l.y / horiz, rise = l.z / horiz;
  const int w = h.width(), ht = h.height();
  for (double t = 0.5;; t += 0.5) {
    const double ray = z + rise * t;
    if (ray > hmax) return true;
    const double px = col + sx * t, py = row + sy * t;
    if (px < 0 || py < 0 || px > w - 1 || py > ht - 1) return true;
    if (HeightAt(h, px, py) > ray + 1e-4) return false;
  }
}

ViewWarp WarpToView(const MaterialMaps& m, const Vec3& view) {
  const Vec3 v = Normalize(view);
  const int w = m.width, ht = m.height;
  const int64_t texels = int64_t(w) * ht;
  ViewWarp out;
  out.col.resize(size_t(texels)), out.row.resize(size_t(texels)), out.z.resize(size_t(texels));
  const Image& h = m.height_map;
  const bool flat = h.empty() || v.z >= 1 - 1e-12;
  float hmin = 0, hmax = 0;
  if (!h.empty()) {
    const auto [lo, hi] = std::minmax_element(h.data().begin(), h.data().end());
    hmin = *lo, hmax = *hi;
  }
  ParallelFor(0, ht, [&](int64_t y0, int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < w; ++x) {
        const int64_t p = int64_t(y) * w + x;
        double col = x, row = y, z = h.empty() ? 0.0 : h.At(0, y, x);
        if (!flat) {
          // The ray's height above the plane is s·v_z at (x + s v_x, y − s v_y). From the camera
          // (large s) down: the first s whose ray point is at or below the surface, found in
          // steps of a quarter texel along the ray's footprint, then refined by bisection.
          auto below = [&](double s) { return s * v.z <= HeightAt(h, x + s * v.x, y - s * v.y); };
          const double s_hi = hmax / v.z, s_lo = hmin / v.z;
          const double step = 0.25 / std::max(std::hypot(v.x, v.y), 0.25);
          double above = s_hi + step, s = s_hi;
          while (s > s_lo && !below(s)) above = s, s -= step;
          s = std::max(s, s_lo);
          for (int k = 0; k < 24; ++k) {  // invariant: below(s), !below(above) (or above = top)
            const double mid = 0.5 * (s + above);
            (below(mid) ? s : above) = mid;
          }
          col = x + s * v.x, row = y - s * v.y, z = s * v.z;
        }
        out.col[size_t(p)] = float(col), out.row[size_t(p)] = float(row),
        out.z[size_t(p)] = float(z);
      }
  });
  std::vector<Tap> taps(static_cast<size_t>(texels));
  for (int64_t p = 0; p < texels; ++p) taps[size_t(p)] = TapAt(w, ht, out.col[p], out.row[p]);
  MaterialMaps& mm = out.maps;
  mm = m;  // model, parameters and per-material values; the texel maps resampled below
  Resample(m.normal, taps, &mm.normal);
  for (int64_t p = 0; p < texels && !mm.normal.empty(); ++p) {
    const Vec3 n =
        Normalize(Vec3(mm.normal.Plane(0)[p], mm.normal.Plane(1)[p], mm.normal.Plane(2)[p]));
    for (int c = 0; c < 3; ++c) mm.normal.Plane(c)[p] = float(n[c]);
  }
  Resample(m.albedo, taps, &mm.albedo);
  Resample(m.specular, taps, &mm.specular);
  Resample(m.exponent, taps, &mm.exponent);
  Resample(m.roughness, taps, &mm.roughness);
  Resample(m.thickness, taps, &mm.thickness);
  Resample(m.translucency, taps, &mm.translucency);
  Resample(m.albedo_back, taps, &mm.albedo_back);
  Resample(m.hl2, taps, &mm.hl2);
  return out;
}

LightStack RenderViews(const MaterialMaps& m, const std::vector<LightSample>& lights,
                       const std::vector<Vec3>& views, bool cast_shadows,
                       const ProgressFn& progress) {
  const int nl = int(lights.size()), nv = int(views.size());
  LightStack stack(m.width, m.height, 3, nl * nv);
  const int64_t texels = int64_t(m.width) * m.height;
  std::vector<Vec3f> dirs;
  for (const LightSample& ls : lights) dirs.emplace_back(ls.direction);
  const float hmax = m.height_map.empty() ? 0.0f
                                          : *std::max_element(m.height_map.data().begin(),
                                                              m.height_map.data().end());
  int frontal = 0;
  for (int k = 1; k < nv; ++k)
    if (views[size_t(k)].z > views[size_t(frontal)].z) frontal = k;
  stack.view_direction = Normalize(views[size_t(frontal)]);
  AnglesDegFromDirection(stack.view_direction, &stack.view_theta_deg, &stack.view_phi_deg);
  std::atomic<int> done{0};
  for (int k = 0; k < nv; ++k) {
    const Vec3 v = Normalize(views[size_t(k)]);
    const ViewWarp warp = WarpToView(m, v);
    const BatchEvaluator eval(warp.maps, dirs, Vec3f(v));
    for (int i = 0; i < nl; ++i) {
      LightSample& ls = stack.lights()[size_t(k) * nl + i];
      ls = lights[size_t(i)];
      ls.has_view = true, ls.view = v;
      AnglesDegFromDirection(v, &ls.view_theta_deg, &ls.view_phi_deg);
    }
    ParallelFor(0, nl, [&](int64_t b, int64_t e) {
      std::vector<float> run(size_t(3) * kEvalRun);
      for (int64_t i = b; i < e; ++i) {
        const int image = k * nl + int(i);
        const Vec3& l = lights[size_t(i)].direction;
        for (int64_t p0 = 0; p0 < texels; p0 += kEvalRun) {
          const int len = int(std::min<int64_t>(kEvalRun, texels - p0));
          eval.Evaluate(int(i), p0, len, 3, run.data());
          for (int c = 0; c < 3; ++c) {
            float* out = stack.Plane(image, c).data() + p0;
            const float intensity = float(lights[size_t(i)].intensity[c]);
            for (int t = 0; t < len; ++t) out[t] = intensity * run[size_t(c * len + t)];
          }
          if (!cast_shadows || m.height_map.empty()) continue;
          for (int t = 0; t < len; ++t) {
            const size_t p = size_t(p0 + t);
            if (stack.Plane(image, 0)[p] == 0 && stack.Plane(image, 1)[p] == 0 &&
                stack.Plane(image, 2)[p] == 0)
              continue;  // dark anyway
            if (!PointSeesLight(m.height_map, hmax, warp.col[p], warp.row[p], warp.z[p], l))
              for (int c = 0; c < 3; ++c) stack.Plane(image, c)[p] = 0.0f;
          }
        }
      }
    });
    if (progress) progress(++done, nv);
  }
  const auto& mk = m.mask.data();
  if (std::any_of(mk.begin(), mk.end(), [](float mv) { return mv <= 0.5f; })) {
    stack.mask.resize(size_t(texels));
    for (int64_t p = 0; p < texels; ++p) stack.mask[p] = mk[p] > 0.5f ? 1 : 0;
  }
  return stack;
}

}  // namespace matfit::synth
