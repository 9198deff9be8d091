#include "core/shading/evaluate.h"

#include <cmath>

#include "core/model/model.h"
#include "core/shading/shading.h"

namespace matfit {

float EvaluateTexel(const MaterialMaps& m, int64_t i, int c, const Vec3f& l, const Vec3f& v) {
  return Model(m.model).Evaluate(m, i, c, l, v);
}

float EvaluateLeafTexel(const MaterialMaps& m, int64_t i, int c, const Vec3f& l, const Vec3f& v) {
  const bool light_up = l.z > 0, view_up = v.z > 0;
  if (light_up && view_up) return EvaluateTexel(m, i, c, l, v);
  const Vec3f lower(l.x, -l.y, -l.z);  // l in the lower side's frame
  if (!light_up && !view_up) {
    const Image& back = m.albedo_back.empty() ? m.albedo : m.albedo_back;
    return shading::Lambert(back.Plane(c)[i], Vec3f(0, 0, 1), lower);
  }
  const Vec3f w = light_up ? l : lower;  // light direction in the lit side's frame
  const float rho_t = m.translucency.Plane(c)[i];
  if (m.hl2.empty()) return shading::DiffuseTranslucency(rho_t, w);
  return shading::Hl2Translucency(rho_t, m.hl2.Plane(0)[i], m.hl2.Plane(1)[i], m.hl2.Plane(2)[i],
                                  w);
}

}  // namespace matfit
