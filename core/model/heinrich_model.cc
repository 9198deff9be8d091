// Seed method A (METHODS.md §2): R_c = t_c a_c + t_c (n_raw·l) [+ L_spec,c max(0, n_s·h)^e].
// Maps: albedo = mean texture t, normal (unit) with normal_scale = |n_raw|, ambient a_c,
// specular_color L_spec,c and a uniform exponent plane (one exponent per material).
#include "core/model/model_impl.h"
#include "core/pack/gltf.h"
#include "core/pack/pack.h"

namespace matfit::model_impl {
namespace {

MATFIT_MODEL_CLONES
void HeinrichDiffuseKernel(const float* __restrict nx, const float* __restrict ny,
                           const float* __restrict nz, const float* __restrict scale,
                           const float* __restrict t, const float* __restrict a, float lx, float ly,
                           float lz, int n, float* __restrict out) {
  const Vec3f l(lx, ly, lz);
  for (int k = 0; k < n; ++k) {
    const float s = scale ? scale[k] : 1.0f;
    out[k] = shading::HeinrichDiffuse(t[k], a[k], Vec3f(nx[k], ny[k], nz[k]) * s, l);
  }
}

class HeinrichModel final : public ModelBase<HeinrichModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kHeinrich; }
  const char* name() const override { return "heinrich"; }
  const char* albedo_semantic() const override { return "mean texture t (seed diffuse texture)"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const override {
    return {{"ambient", &m.ambient},
            {"normal_scale", &m.normal_scale},
            {"specular_color", &m.specular_color}};
  }
  bool has_truth_albedo() const override { return false; }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f& v) const override {
    const Vec3f n = NormalAt(m, i);
    const float scale = m.normal_scale.empty() ? 1.0f : m.normal_scale.Plane(0)[i];
    float r = shading::HeinrichDiffuse(m.albedo.Plane(c)[i], m.ambient.Plane(c)[i], n * scale, l);
    if (!m.specular_color.empty()) {
      const Vec3f ns = m.specular_flat_normal ? Vec3f(0, 0, 1) : n;
      r +=
          shading::HeinrichSpecular(m.specular_color.Plane(c)[i], m.exponent.Plane(0)[i], ns, l, v);
    }
    return r;
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    const DiffusePlanes d(m, p0);
    const float* scale = m.normal_scale.empty() ? nullptr : m.normal_scale.Plane(0).data() + p0;
    for (int c = 0; c < channels; ++c)
      HeinrichDiffuseKernel(d.nx, d.ny, d.nz, scale, d.albedo[c], m.ambient.Plane(c).data() + p0,
                            light.l.x, light.l.y, light.l.z, n, out + c * n);
    if (m.specular_color.empty()) return;
    // The lobe is L_spec,c · max(0, n_s·h)^e: the channel-free factor (L_spec = 1) once per
    // texel, then scaled per channel (the same product the per-sample path forms).
    const float* e = m.exponent.Plane(0).data() + p0;
    float lobe[kEvalRun];
    for (int t0 = 0; t0 < n; t0 += kEvalRun) {
      const int len = std::min(kEvalRun, n - t0);
      for (int t = 0; t < len; ++t) {
        const int k = t0 + t;
        const Vec3f ns = m.specular_flat_normal ? Vec3f(0, 0, 1) : Vec3f(d.nx[k], d.ny[k], d.nz[k]);
        lobe[t] = shading::HeinrichSpecular(1.0f, e[k], ns, light.l, light.v);
      }
      for (int c = 0; c < channels; ++c) {
        const float* ls = m.specular_color.Plane(c).data() + p0 + t0;
        for (int t = 0; t < len; ++t) out[c * n + t0 + t] += ls[t] * lobe[t];
      }
    }
  }
  Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const override {
    const PackMap maps[] = {
        {"ambient", "ambient.exr", &m.ambient, MapEncoding::kFloat, "ambient factor a_c"},
        {"normal_scale", "normal_scale.exr", &m.normal_scale, MapEncoding::kFloat,
         "|n| of the unnormalised fitted normal"},
        {"specular_exact", "specular.exr", &m.specular_color, MapEncoding::kFloat,
         "L_spec residual of sample #1 (may be negative)"},
        {"specular", "specular.png", &m.specular_color, MapEncoding::kLinear8,
         "L_spec clamped to [0,1]"}};
    for (const PackMap& pm : maps) MATFIT_RETURN_IF_ERROR(put(pm));
    MATFIT_RETURN_IF_ERROR(PutGltfSpecular(m, SpecularPeak(m), m.exponent, put));
    // glTF (Gltf below): R = t a + t |n_raw| (n̂·l) is a Lambertian base colour t |n_raw| plus a
    // term the light's direction does not change, t a: emission at unit light.
    Image base, emissive;
    if (GltfBake(m, &base, &emissive)) {
      MATFIT_RETURN_IF_ERROR(
          put({"gltf_base_color", "gltf_base_color.png", &base, MapEncoding::kSrgb8,
               "glTF base colour t |n_raw| (clamped to 1)"}));
      MATFIT_RETURN_IF_ERROR(
          put({"gltf_emissive", "gltf_emissive.png", &emissive, MapEncoding::kSrgb8,
               "glTF emission t a: the ambient term at unit light"}));
    }
    return Status::Ok();
  }
  // The lobe's peak per texel: the mean of L_spec over the channels (glTF's F0 texture is grey
  // here: one colour per material would need a colour texture per channel's share).
  static Image SpecularPeak(const MaterialMaps& m) {
    if (m.specular_color.empty()) return Image();
    Image peak(m.width, m.height, 1);
    const int ch = m.specular_color.channels();
    for (int64_t p = 0; p < peak.plane_size(); ++p) {
      double s = 0;
      for (int c = 0; c < ch; ++c) s += m.specular_color.Plane(c)[p];
      peak.Plane(0)[p] = float(s / ch);
    }
    return peak;
  }
  // t |n_raw| (+ 9 t a / 7 where a < 0) and max(0, t a) per channel; false without the maps.
  // *clipped counts values cut to [0, 1].
  static bool GltfBake(const MaterialMaps& m, Image* base, Image* emissive,
                       int64_t* clipped = nullptr) {
    if (m.albedo.channels() != 3 || m.ambient.channels() != 3) return false;
    const int64_t n = int64_t(m.width) * m.height;
    *base = Image(m.width, m.height, 3), *emissive = Image(m.width, m.height, 3);
    int64_t cut = 0;
    for (int c = 0; c < 3; ++c)
      for (int64_t p = 0; p < n; ++p) {
        const float t = m.albedo.Plane(c)[p],
                    s = m.normal_scale.empty() ? 1 : m.normal_scale.Plane(0)[p];
        float b = t * s, e = t * m.ambient.Plane(c)[p];
        // A negative ambient (a fit that darkens oblique light less than a cosine) cannot be
        // emitted: it goes into the base colour as the least-squares Lambertian of
        // t a + t|n| cos θ over lights within 60° of the normal (cos θ uniform on [½, 1]:
        // b = t|n| + t a ⟨cos⟩/⟨cos²⟩, ⟨cos⟩/⟨cos²⟩ = 0.75/0.58333 = 9/7).
        if (e < 0) b += e * 9.0f / 7.0f, e = 0;
        cut += (b < 0 || b > 1 || e > 1) ? 1 : 0;
        base->Plane(c)[p] = std::clamp(b, 0.0f, 1.0f);
        emissive->Plane(c)[p] = std::clamp(e, 0.0f, 1.0f);
      }
    if (clipped) *clipped = cut;
    return true;
  }
  void PackParameters(const MaterialMaps& m, std::map<std::string, double>* out) const override {
    (*out)["specular_flat_normal"] = m.specular_flat_normal ? 1 : 0;
  }
  Status ReadPackMaps(const LoadPackMapFn& load, const std::map<std::string, double>& params,
                      MaterialMaps* m) const override {
    MATFIT_RETURN_IF_ERROR(load("ambient", &m->ambient));
    MATFIT_RETURN_IF_ERROR(load("normal_scale", &m->normal_scale));
    MATFIT_RETURN_IF_ERROR(load("specular_exact", &m->specular_color));
    auto flat = params.find("specular_flat_normal");
    m->specular_flat_normal = flat != params.end() && flat->second != 0;
    if (!m->specular_color.empty()) {
      auto e = params.find("exponent");
      m->exponent = Image(m->albedo.width(), m->albedo.height(), 1,
                          float(e == params.end() ? 1.0 : e->second));
    }
    return Status::Ok();
  }
  // glTF cannot express the ambient term or |n_raw|: base colour = t, specular colour L_spec
  // with the roughness of the shared exponent.
  void Gltf(const MaterialMaps& m, const std::vector<uint8_t>&,
            const std::map<std::string, double>& fit_parameters,
            GltfMaterialDesc* g) const override {
    Image base, emissive;
    int64_t clipped = 0;
    if (GltfBake(m, &base, &emissive, &clipped)) {
      g->base_color_uri = "maps/gltf_base_color.png";
      g->emissive_uri = "maps/gltf_emissive.png";
      g->approximations.push_back(
          "heinrich's unnormalised normal and ambient term: base colour = t |n_raw| "
          "(maps/gltf_base_color.png), emission = t a (maps/gltf_emissive.png), exact at unit "
          "light for lights in front (glTF clamps n.l at 0 where the model does not); the "
          "emission does not follow the light's intensity; where a < 0 (no negative emission) "
          "the base colour is t (|n_raw| + 9a/7), the least-squares Lambertian for lights "
          "within 60 degrees of the normal");
      if (clipped > 0)
        g->approximations.push_back(std::to_string(clipped) +
                                    " texel channel values cut to [0, 1] for the glTF maps");
    }
    if (m.specular_color.empty()) return;
    auto e = fit_parameters.find("exponent");
    if (e != fit_parameters.end()) g->roughness = RoughnessFromBlinnPhongExponent(e->second);
    GltfSpecular(m, SpecularPeak(m), m.exponent, "heinrich's specular L_spec (n_s.h)^e", g);
  }
  bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* s) const override {
    if (!s->Add(m.ambient, 3, "ambient")) return false;
    if (m.normal_scale.empty())
      s->AddOnes();
    else if (!s->Add(m.normal_scale, 1, "normal_scale"))
      return false;
    s->heinrich_specular = !m.specular_color.empty();
    s->flat_normal = m.specular_flat_normal;
    if (!s->heinrich_specular) return true;
    return s->Add(m.specular_color, 3, "specular_color") && s->Add(m.exponent, 1, "exponent");
  }
};

}  // namespace

const ModelDescriptor& HeinrichDescriptor() {
  static const HeinrichModel model;
  return model;
}

}  // namespace matfit::model_impl
