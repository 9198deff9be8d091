#include "core/synth/render_stack.h"

#include <atomic>

#include <algorithm>
#include <cmath>

#include "core/model/model.h"
#include "core/near_lights.h"
#include "core/parallel.h"

namespace matfit::synth {
namespace {

float Bilinear(const Image& h, double x, double y) {
  // Clamp to the border: the sample does not continue outside the frame.
  x = std::clamp(x, 0.0, double(h.width() - 1));
  y = std::clamp(y, 0.0, double(h.height() - 1));
  const int x0 = std::max(0, std::min(int(x), h.width() - 2));
  const int y0 = std::max(0, std::min(int(y), h.height() - 2));
  const int x1 = std::min(x0 + 1, h.width() - 1), y1 = std::min(y0 + 1, h.height() - 1);
  const double fx = x - x0, fy = y - y0;
  return float((h.At(0, y0, x0) * (1 - fx) + h.At(0, y0, x1) * fx) * (1 - fy) +
               (h.At(0, y1, x0) * (1 - fx) + h.At(0, y1, x1) * fx) * fy);
}

}  // namespace

Image CastShadowVisibility(const Image& h, const Vec3& light) {
  const int w = h.width(), ht = h.height();
  Image vis(w, ht, 1, 1.0f);
  const double horiz = std::hypot(light.x, light.y);
  if (horiz < 1e-9 || light.z <= 0) {
    if (light.z <= 0) std::fill(vis.data().begin(), vis.data().end(), 0.0f);
    return vis;  // light overhead: nothing is shadowed; below the horizon: all dark
  }
  const float hmax = *std::max_element(h.data().begin(), h.data().end());
  // Image step per unit horizontal distance; y up means rows decrease toward +y.
  const double sx = light.x / horiz, sy = -light.y / horiz;
  const double rise = light.z / horiz;  // height gained per texel travelled
  const double step = 0.5;
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const double h0 = h.At(0, y, x);
      for (double t = step;; t += step) {
        const double ray = h0 + rise * t;
        if (ray > hmax) break;
        const double px = x + sx * t, py = y + sy * t;
        if (px < 0 || py < 0 || px > w - 1 || py > ht - 1) break;
        if (Bilinear(h, px, py) > ray + 1e-4) {
          vis.At(0, y, x) = 0.0f;
          break;
        }
      }
    }
  return vis;
}

LightStack RenderStack(const MaterialMaps& m, const std::vector<LightSample>& lights,
                       const RenderOptions& options, const ProgressFn& progress) {
  const int n = int(lights.size());
  LightStack stack(m.width, m.height, 3, n);
  stack.lights() = lights;
  stack.view_direction = options.view;
  AnglesDegFromDirection(options.view, &stack.view_theta_deg, &stack.view_phi_deg);
  const Vec3f v(Normalize(options.view));
  const int64_t texels = int64_t(m.width) * m.height;
  std::vector<Vec3f> dirs;
  for (const LightSample& ls : lights) dirs.emplace_back(ls.direction);
  const BatchEvaluator eval(m, dirs, v);
  // Near lights: texel (x, y) at (x + ½ − W/2, H/2 − y − ½, 0), lit along its own direction
  // with its own fall-off (core/near_lights.h), evaluated sample by sample.
  const bool near = !lights.empty() && lights[0].has_position;
  if (near) stack.near_frame = {0.5 - 0.5 * m.width, 0.5 * m.height - 0.5, 1.0};
  std::atomic<int64_t> rendered{0};
  ParallelFor(0, n, [&](int64_t b, int64_t e) {
    std::vector<float> run(size_t(3) * kEvalRun);
    std::vector<int64_t> idx(near ? kEvalRun : 0);
    std::vector<Vec3> points(near ? kEvalRun : 0);
    NearLightEvaluator near_eval(m, v);
    for (int64_t i = b; i < e; ++i) {
      const LightSample& ls = lights[i];
      Image vis;
      if (options.cast_shadows) vis = CastShadowVisibility(m.height_map, ls.direction);
      for (int64_t p0 = 0; p0 < texels; p0 += kEvalRun) {
        const int len = int(std::min<int64_t>(kEvalRun, texels - p0));
        if (near) {
          for (int t = 0; t < len; ++t) {
            const int64_t p = p0 + t;
            idx[size_t(t)] = p;
            points[size_t(t)] = NearTexelPosition(stack, double(p % m.width), double(p / m.width));
          }
          near_eval.Evaluate(ls, idx.data(), points.data(), len, run.data());
        } else {
          eval.Evaluate(int(i), p0, len, 3, run.data());
        }
        for (int c = 0; c < 3; ++c) {
          float* out = stack.Plane(int(i), c).data() + p0;
          const float intensity = float(ls.intensity[c]);
          for (int t = 0; t < len; ++t) {
            const float visible = options.cast_shadows ? vis.data()[p0 + t] : 1.0f;
            out[t] = visible > 0 ? intensity * run[size_t(c * len + t)] : 0.0f;
          }
        }
      }
      if (progress) progress(++rendered, n);
    }
  });
  const auto& mk = m.mask.data();
  if (std::any_of(mk.begin(), mk.end(), [](float mv) { return mv <= 0.5f; })) {
    stack.mask.resize(size_t(texels));  // only materials with a background carry a mask
    for (int64_t p = 0; p < texels; ++p) stack.mask[p] = mk[p] > 0.5f ? 1 : 0;
  }
  return stack;
}

}  // namespace matfit::synth
