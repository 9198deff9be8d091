// Lafortune (METHODS.md §4): Lambert + Σ_j isotropic lobes ρ_s,j max(0, D_j)^e_j max(0, n·l).
// Maps: specular (one amplitude plane per lobe), lobe_shape (2j = C_xy, 2j + 1 = exponent).
#include "core/model/model_impl.h"
#include "core/pack/pack.h"

namespace matfit::model_impl {
namespace {

// The first lobe's amplitude plane.
Image FirstLobe(const MaterialMaps& m) {
  if (m.specular.empty()) return {};
  Image a(m.width, m.height, 1);
  std::copy(m.specular.Plane(0).begin(), m.specular.Plane(0).end(), a.Plane(0).begin());
  return a;
}

class LafortuneModel final : public ModelBase<LafortuneModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kLafortune; }
  const char* name() const override { return "lafortune"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const override {
    return {{"specular", &m.specular}, {"lobe_shape", &m.lobe_shape}};
  }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f& v) const override {
    const Vec3f n = NormalAt(m, i);
    float r = shading::Lambert(m.albedo.Plane(c)[i], n, l);
    for (int j = 0; j < m.specular.channels(); ++j)
      r += shading::LafortuneLobe(m.specular.Plane(j)[i], m.lobe_shape.Plane(2 * j)[i],
                                  m.lobe_shape.Plane(2 * j + 1)[i], n, l, v);
    return r;
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    const DiffusePlanes d(m, p0);
    LambertRun(d, light.l, n, channels, out);
    for (int j = 0; j < m.specular.channels(); ++j) {
      const float* rho = m.specular.Plane(j).data() + p0;
      const float* cxy = m.lobe_shape.Plane(2 * j).data() + p0;
      const float* e = m.lobe_shape.Plane(2 * j + 1).data() + p0;
      AddLobeRun(n, channels, out, [&](int t) {
        return shading::LafortuneLobe(rho[t], cxy[t], e[t], Vec3f(d.nx[t], d.ny[t], d.nz[t]),
                                      light.l, light.v);
      });
    }
  }
  // glTF: the first lobe as the GGX of a Blinn–Phong lobe with the same head-on peak ρ_s and
  // curvature (exponent 4 e, LafortuneEquivalentExponent).
  Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const override {
    MATFIT_RETURN_IF_ERROR(
        PutLobeMaps(m, put, "Lafortune lobe amplitudes rho_s,j",
                    MetallicRoughness(m, [](const MaterialMaps& mm, int64_t p) {
                      return float(RoughnessFromBlinnPhongExponent(4 * mm.lobe_shape.Plane(1)[p]));
                    })));
    return PutGltfSpecular(m, FirstLobe(m), LafortuneEquivalentExponent(m), put);
  }
  Status ReadPackMaps(const LoadPackMapFn& load, const std::map<std::string, double>&,
                      MaterialMaps* m) const override {
    return LoadLobeMaps(load, m);
  }
  void Gltf(const MaterialMaps& m, const std::vector<uint8_t>&,
            const std::map<std::string, double>&, GltfMaterialDesc* g) const override {
    LobeGltf(g);
    GltfSpecular(m, FirstLobe(m), LafortuneEquivalentExponent(m),
                 m.specular.channels() > 1
                     ? "Lafortune's first lobe rho_s D^e (n.l) (the others are left out)"
                     : "Lafortune lobe rho_s D^e (n.l), as Blinn-Phong exponent 4e",
                 g);
  }
  bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* s) const override {
    s->terms = m.specular.channels();
    if (s->terms < 1 || s->terms > 4) return false;  // material.frag has room for 4 lobes
    return s->Add(m.specular, s->terms, "specular (ρ_s)") &&
           s->Add(m.lobe_shape, 2 * s->terms, "lobe_shape");
  }
};

}  // namespace

const ModelDescriptor& LafortuneDescriptor() {
  static const LafortuneModel model;
  return model;
}

}  // namespace matfit::model_impl
