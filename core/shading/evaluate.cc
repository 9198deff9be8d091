#include "core/shading/evaluate.h"

#include <cmath>

#include "core/shading/relight_basis.h"
#include "core/shading/shading.h"

namespace matfit {

float EvaluateTexel(const MaterialMaps& m, int64_t i, int c, const Vec3f& l, const Vec3f& v) {
  if (m.model == ShadingModel::kMean) return m.albedo.Plane(c)[i];
  if (m.model == ShadingModel::kPtm || m.model == ShadingModel::kHsh) {
    double b[shading::kMaxHshTerms];
    const int k = m.basis_terms;
    if (m.model == ShadingModel::kPtm)
      shading::PtmBasis(Vec3(l), b);
    else
      shading::HshBasis(int(std::lround(std::sqrt(double(k)))), Vec3(l), b);
    const int base = (m.coefficients.channels() == k ? 0 : c) * k;
    double r = 0;
    for (int j = 0; j < k; ++j) r += b[j] * m.coefficients.Plane(base + j)[i];
    return float(r);
  }
  const Vec3f n(m.normal.Plane(0)[i], m.normal.Plane(1)[i], m.normal.Plane(2)[i]);
  if (m.model == ShadingModel::kHeinrich) {
    const float scale = m.normal_scale.empty() ? 1.0f : m.normal_scale.Plane(0)[i];
    float r = shading::HeinrichDiffuse(m.albedo.Plane(c)[i], m.ambient.Plane(c)[i], n * scale, l);
    if (!m.specular_color.empty()) {
      const Vec3f ns = m.specular_flat_normal ? Vec3f(0, 0, 1) : n;
      r +=
          shading::HeinrichSpecular(m.specular_color.Plane(c)[i], m.exponent.Plane(0)[i], ns, l, v);
    }
    return r;
  }
  float r = shading::Lambert(m.albedo.Plane(c)[i], n, l);
  switch (m.model) {
    case ShadingModel::kBlinnPhong:
      r += shading::BlinnPhongSpecular(m.specular.Plane(0)[i], m.exponent.Plane(0)[i], n, l, v);
      break;
    case ShadingModel::kCookTorrance:
      r += shading::CookTorranceSpecular(m.specular.Plane(0)[i], m.roughness.Plane(0)[i], n, l, v);
      break;
    case ShadingModel::kLafortune:
      for (int j = 0; j < m.specular.channels(); ++j)
        r += shading::LafortuneLobe(m.specular.Plane(j)[i], m.lobe_shape.Plane(2 * j)[i],
                                    m.lobe_shape.Plane(2 * j + 1)[i], n, l, v);
      break;
    default: break;
  }
  return r;
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
