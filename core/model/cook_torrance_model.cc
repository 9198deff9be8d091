// Cook–Torrance (METHODS.md §4): Lambert + π D_GGX G_Smith F_Schlick / (4 n·v). Maps: specular
// (F0), roughness (perceptual r, α = r²).
#include <algorithm>
#include <cmath>

#include "core/model/model_impl.h"
#include "core/pack/gltf.h"

namespace matfit::model_impl {
namespace {

class CookTorranceModel final : public ModelBase<CookTorranceModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kCookTorrance; }
  const char* name() const override { return "cook-torrance"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const override {
    return {{"specular", &m.specular}, {"roughness", &m.roughness}};
  }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f& v) const override {
    const Vec3f n = NormalAt(m, i);
    return shading::Lambert(m.albedo.Plane(c)[i], n, l) +
           shading::CookTorranceSpecular(m.specular.Plane(0)[i], m.roughness.Plane(0)[i], n, l, v);
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    const DiffusePlanes d(m, p0);
    LambertRun(d, light.l, n, channels, out);
    const float* f0 = m.specular.Plane(0).data() + p0;
    const float* r = m.roughness.Plane(0).data() + p0;
    AddLobeRun(n, channels, out, [&](int t) {
      return shading::CookTorranceSpecularHalf(f0[t], r[t], Vec3f(d.nx[t], d.ny[t], d.nz[t]),
                                               light.l, light.v, light.h);
    });
  }
  Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const override {
    return PutLobeMaps(m, put, "Cook-Torrance F0",
                       MetallicRoughness(m, [](const MaterialMaps& mm, int64_t p) {
                         return mm.roughness.Plane(0)[p];
                       }));
  }
  Status ReadPackMaps(const LoadPackMapFn& load, const std::map<std::string, double>&,
                      MaterialMaps* m) const override {
    return LoadLobeMaps(load, m);
  }
  // The median fitted F0 as an index of refraction: η = (1 + √F0) / (1 − √F0).
  void Gltf(const MaterialMaps& m, const std::vector<uint8_t>& status,
            const std::map<std::string, double>&, GltfMaterialDesc* g) const override {
    LobeGltf(g);
    std::vector<float> f0;
    for (size_t p = 0; p < status.size(); ++p)
      if (status[p] == 0) f0.push_back(m.specular.data()[p]);
    if (f0.empty()) return;
    std::nth_element(f0.begin(), f0.begin() + f0.size() / 2, f0.end());
    const double r0 = std::sqrt(std::clamp(double(f0[f0.size() / 2]), 0.0, 0.81));
    g->ior = (1 + r0) / (1 - r0);
  }
  bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* s) const override {
    return s->Add(m.specular, 1, "specular (F0)") && s->Add(m.roughness, 1, "roughness");
  }
  bool synthesizable() const override { return true; }
  void InitTruthMaps(int w, int h, MaterialMaps* m) const override {
    m->specular = Image(w, h, 1), m->roughness = Image(w, h, 1);
  }
  void SetTruthTexel(int x, int y, const TruthLobe& lobe, MaterialMaps* m) const override {
    m->specular.At(0, y, x) = float(lobe.specular);
    m->roughness.At(0, y, x) = float(lobe.roughness);
  }
  const char* truth_formula() const override {
    return "pi * D_GGX * G_Smith * F_Schlick / (4 n.l n.v) * n.l, alpha = roughness^2";
  }
  const char* truth_specular_semantic() const override { return "specular.exr (F0)"; }
  void TruthParameters(const MaterialMaps& m, std::map<std::string, double>* out) const override {
    // A material-wide roughness only when the map is one value (lacquer's varies per texel).
    const auto& r = m.roughness.data();
    if (!r.empty() && std::all_of(r.begin(), r.end(), [&](float v) { return v == r[0]; }))
      (*out)["roughness"] = r[0];
  }
};

}  // namespace

const ModelDescriptor& CookTorranceDescriptor() {
  static const CookTorranceModel model;
  return model;
}

}  // namespace matfit::model_impl
