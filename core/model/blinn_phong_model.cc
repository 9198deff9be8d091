// Blinn–Phong (METHODS.md §4): Lambert + k_s max(0, n·h)^e max(0, n·l). Maps: specular (k_s),
// exponent.
#include <algorithm>
#include <cmath>

#include "core/model/model_impl.h"
#include "core/pack/gltf.h"
#include "core/pack/pack.h"

namespace matfit::model_impl {
namespace {

class BlinnPhongModel final : public ModelBase<BlinnPhongModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kBlinnPhong; }
  const char* name() const override { return "blinn-phong"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const override {
    return {{"specular", &m.specular}, {"exponent", &m.exponent}};
  }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f& v) const override {
    const Vec3f n = NormalAt(m, i);
    return shading::Lambert(m.albedo.Plane(c)[i], n, l) +
           shading::BlinnPhongSpecular(m.specular.Plane(0)[i], m.exponent.Plane(0)[i], n, l, v);
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    const DiffusePlanes d(m, p0);
    LambertRun(d, light.l, n, channels, out);
    const float* ks = m.specular.Plane(0).data() + p0;
    const float* e = m.exponent.Plane(0).data() + p0;
    AddLobeRun(n, channels, out, [&](int t) {
      return shading::BlinnPhongSpecularHalf(ks[t], e[t], Vec3f(d.nx[t], d.ny[t], d.nz[t]), light.l,
                                             light.h);
    });
  }
  Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const override {
    MATFIT_RETURN_IF_ERROR(PutLobeMaps(
        m, put, "Blinn-Phong k_s", MetallicRoughness(m, [](const MaterialMaps& mm, int64_t p) {
          return float(RoughnessFromBlinnPhongExponent(mm.exponent.Plane(0)[p]));
        })));
    // glTF specular colour: each texel's F0 relative to the material's (Gltf below).
    return PutGltfSpecular(m, m.specular, m.exponent, put);
  }
  Status ReadPackMaps(const LoadPackMapFn& load, const std::map<std::string, double>&,
                      MaterialMaps* m) const override {
    return LoadLobeMaps(load, m);
  }
  void Gltf(const MaterialMaps& m, const std::vector<uint8_t>& status,
            const std::map<std::string, double>&, GltfMaterialDesc* g) const override {
    LobeGltf(g);
    (void)status;
    GltfSpecular(m, m.specular, m.exponent, "Blinn-Phong lobe k_s (n.h)^e (n.l)", g);
  }
  bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* s) const override {
    return s->Add(m.specular, 1, "specular") && s->Add(m.exponent, 1, "exponent");
  }
  bool synthesizable() const override { return true; }
  void InitTruthMaps(int w, int h, MaterialMaps* m) const override {
    m->specular = Image(w, h, 1), m->exponent = Image(w, h, 1);
  }
  void SetTruthTexel(int x, int y, const TruthLobe& lobe, MaterialMaps* m) const override {
    m->specular.At(0, y, x) = float(lobe.specular);
    m->exponent.At(0, y, x) = float(lobe.exponent);
  }
  const char* truth_formula() const override {
    return "k_s * max(0, n.h)^e * max(0, n.l), not energy-normalised";
  }
  const char* truth_specular_semantic() const override { return "specular.exr (k_s)"; }
  void TruthParameters(const MaterialMaps& m, std::map<std::string, double>* out) const override {
    if (!m.exponent.empty()) (*out)["exponent"] = m.exponent.data()[0];
  }
};

}  // namespace

const ModelDescriptor& BlinnPhongDescriptor() {
  static const BlinnPhongModel model;
  return model;
}

}  // namespace matfit::model_impl
