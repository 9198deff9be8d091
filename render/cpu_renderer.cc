#include "render/cpu_renderer.h"

#include "core/model/model.h"
#include "core/pack/shader_params.h"
#include "core/parallel.h"
#include "core/shading/evaluate.h"
#include "render/scene.h"

namespace matfit::render {

StatusOr<Image> RenderCpu(const MaterialMaps& m, const RenderOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  // The same completeness checks as the GPU path.
  if (Status st = CheckShaderMaps(m); !st.ok()) return st;
  const int S = o.size;
  Image out(S, S, 4);
  const CameraFrame cam = MakeCamera(o.camera_theta_deg, o.camera_phi_deg);
  const Vec3f light(o.LightDirection()), v = cam.v;
  const Vec3f radiance = Vec3f(o.light_color) * float(o.intensity);
  const float ambient = float(o.ambient);
  const ModelDescriptor& model = Model(m.model);
  const bool leaf = !m.translucency.empty();  // two-sided: light from behind transmits
  ParallelFor(0, S, [&](int64_t y0, int64_t y1) {
    // One row's hits, then one scattered evaluation of the row (no per-sample dispatch).
    std::vector<int64_t> texel(static_cast<size_t>(S)), pixel(static_cast<size_t>(S));
    std::vector<Vec3f> lts(static_cast<size_t>(S)), vts(static_cast<size_t>(S));
    std::vector<float> f(size_t(3) * S);
    for (int64_t py = y0; py < y1; ++py) {
      int k = 0;
      for (int px = 0; px < S; ++px) {
        const SceneHit h = HitScene(o.scene, cam, S, px, int(py), m.width, m.height);
        const int64_t p = int64_t(h.ty) * m.width + h.tx, q = py * S + px;
        if (!h.hit || (!m.mask.empty() && m.mask.Plane(0)[p] < 0.5f)) continue;  // background
        const bool lit = leaf || Dot(light, h.n) > 0.0f;
        out.Plane(3)[q] = 1.0f;
        if (!lit) {
          for (int c = 0; c < 3; ++c) {
            const float color = ambient * m.albedo.Plane(c)[p];
            out.Plane(c)[q] = o.display ? DisplayEncode(color, o) : color;
          }
          continue;
        }
        texel[size_t(k)] = p, pixel[size_t(k)] = q;
        lts[size_t(k)] = Vec3f(Dot(light, h.t), Dot(light, h.b), Dot(light, h.n));
        vts[size_t(k)] = Vec3f(Dot(v, h.t), Dot(v, h.b), Dot(v, h.n));
        ++k;
      }
      if (leaf) {
        for (int j = 0; j < k; ++j)
          for (int c = 0; c < 3; ++c)
            f[size_t(c * k + j)] =
                EvaluateLeafTexel(m, texel[size_t(j)], c, lts[size_t(j)], vts[size_t(j)]);
      } else {
        model.EvaluateSamples(m, texel.data(), lts.data(), vts.data(), k, f.data());
      }
      for (int j = 0; j < k; ++j)
        for (int c = 0; c < 3; ++c) {
          const int64_t p = texel[size_t(j)];
          const float color = radiance[c] * f[size_t(c * k + j)] + ambient * m.albedo.Plane(c)[p];
          out.Plane(c)[pixel[size_t(j)]] = o.display ? DisplayEncode(color, o) : color;
        }
    }
  });
  return out;
}

StatusOr<Image> RenderLeafPreview(const MaterialMaps& maps, bool from_behind, int size) {
  RenderOptions ro;
  ro.size = size, ro.theta_deg = from_behind ? 150 : 30, ro.phi_deg = 45, ro.ambient = 0.02;
  return RenderCpu(maps, ro);
}

}  // namespace matfit::render
