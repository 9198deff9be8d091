// The descriptor's shared parts: default light preparation, the batched evaluator, the
// vectorised Lambert run and the lobe models' pack maps.
#include <cmath>

#include "core/check.h"
#include "core/model/model_impl.h"
#include "core/pack/gltf.h"
#include "core/pack/gltf_bake.h"
#include "core/pack/pack.h"

namespace matfit {

int ModelDescriptor::ParameterPlanes(const MaterialMaps& m) const {
  int planes = (writes_normal_map() ? 3 : 0) + 3;
  for (const auto& [name, img] : ParameterMaps(m)) planes += img->empty() ? 0 : img->channels();
  return planes;
}

void ModelDescriptor::Prepare(const MaterialMaps& m, const Vec3f& l, const Vec3f& v,
                              ModelLight* out) const {
  (void)m;
  out->l = l, out->v = v, out->h = Normalize(l + v);
}

void ModelDescriptor::EvaluateLights(const MaterialMaps& m, const ModelLight* lights, int count,
                                     int64_t p0, int n, int channels, float* out) const {
  for (int l = 0; l < count; ++l)
    EvaluateBatch(m, lights[l], p0, n, channels, out + size_t(l) * channels * n);
}

BatchEvaluator::BatchEvaluator(const MaterialMaps& maps, const std::vector<Vec3f>& lights,
                               const Vec3f& view)
    : maps_(&maps), model_(&Model(maps.model)), prepared_(lights.size()) {
  for (size_t i = 0; i < lights.size(); ++i) model_->Prepare(maps, lights[i], view, &prepared_[i]);
}

BatchEvaluator::BatchEvaluator(const MaterialMaps& maps, const std::vector<Vec3f>& lights,
                               const std::vector<Vec3f>& views)
    : maps_(&maps), model_(&Model(maps.model)), prepared_(lights.size()) {
  MATFIT_CHECK(views.size() == lights.size(), "BatchEvaluator: one view per light");
  for (size_t i = 0; i < lights.size(); ++i)
    model_->Prepare(maps, lights[i], views[i], &prepared_[i]);
}

namespace model_impl {

MATFIT_MODEL_CLONES
static void LambertKernel(const float* __restrict nx, const float* __restrict ny,
                          const float* __restrict nz, const float* __restrict a, float lx, float ly,
                          float lz, int n, float* __restrict out) {
  const Vec3f l(lx, ly, lz);
  for (int t = 0; t < n; ++t) out[t] = shading::Lambert(a[t], Vec3f(nx[t], ny[t], nz[t]), l);
}

void LambertRun(const DiffusePlanes& d, const Vec3f& l, int n, int channels, float* out) {
  for (int c = 0; c < channels; ++c)
    LambertKernel(d.nx, d.ny, d.nz, d.albedo[c], l.x, l.y, l.z, n, out + c * n);
}

Image MetallicRoughness(const MaterialMaps& m,
                        float (*roughness_at)(const MaterialMaps&, int64_t)) {
  Image mr(m.width, m.height, 3);
  for (int64_t p = 0; p < int64_t(m.width) * m.height; ++p) {
    mr.Plane(0)[p] = 1.0f;
    mr.Plane(1)[p] = roughness_at(m, p);
  }
  return mr;
}

Status PutLobeMaps(const MaterialMaps& m, const PutPackMapFn& put, const char* specular_semantic,
                   const Image& metallic_roughness) {
  const PackMap maps[] = {
      {"specular", "specular.exr", &m.specular, MapEncoding::kFloat, specular_semantic},
      {"roughness", "roughness.exr", &m.roughness, MapEncoding::kFloat,
       "GGX perceptual roughness r (alpha = r^2)"},
      {"exponent", "exponent.exr", &m.exponent, MapEncoding::kFloat, "Blinn-Phong exponent e"},
      {"lobe_shape", "lobe_shape.exr", &m.lobe_shape, MapEncoding::kFloat,
       "Lafortune lobe j: C_xy (2j), exponent (2j+1)"},
      {"metallic_roughness", "metallic_roughness.png", &metallic_roughness, MapEncoding::kLinear8,
       "glTF: G = roughness, B = metallic (0)"}};
  for (const PackMap& pm : maps) MATFIT_RETURN_IF_ERROR(put(pm));
  return Status::Ok();
}

Status LoadLobeMaps(const LoadPackMapFn& load, MaterialMaps* m) {
  MATFIT_RETURN_IF_ERROR(load("specular", &m->specular));
  MATFIT_RETURN_IF_ERROR(load("exponent", &m->exponent));
  MATFIT_RETURN_IF_ERROR(load("roughness", &m->roughness));
  return load("lobe_shape", &m->lobe_shape);
}

namespace {

// F0 = 8 peak / (e + 2) per texel (0 where the lobe is undefined).
Image LobeF0(const MaterialMaps& m, const Image& peak, const Image& exponent) {
  Image f0(m.width, m.height, 1);
  if (peak.empty() || exponent.empty()) return f0;
  for (int64_t p = 0; p < f0.plane_size(); ++p) {
    const double ks = peak.Plane(0)[p], e = exponent.Plane(0)[p];
    f0.Plane(0)[p] = std::isfinite(ks) && std::isfinite(e) && e > -2
                         ? float(std::max(0.0, 8 * ks / (e + 2)))
                         : 0.0f;
  }
  return f0;
}

}  // namespace

Status PutGltfSpecular(const MaterialMaps& m, const Image& peak, const Image& exponent,
                       const PutPackMapFn& put) {
  GltfF0 split = SplitF0ForGltf(LobeF0(m, peak, exponent), m.mask);
  if (!(split.ior > 0)) return Status::Ok();
  return put({"gltf_specular", "gltf_specular.png", &split.share, MapEncoding::kSrgb8,
              "glTF specular colour: each texel's F0 = 8 peak / (e + 2) over the IOR's F0"});
}

void GltfSpecular(const MaterialMaps& m, const Image& peak, const Image& exponent, const char* lobe,
                  GltfMaterialDesc* g) {
  const GltfF0 split = SplitF0ForGltf(LobeF0(m, peak, exponent), m.mask);
  if (!(split.ior > 0)) return;
  g->ior = split.ior;
  g->specular_color_uri = "maps/gltf_specular.png";
  g->specular_factor = 1.0;
  g->approximations.push_back(std::string(lobe) +
                              " as GGX: roughness (2/(e+2))^(1/4), F0 = 8 peak/(e+2) (the same "
                              "head-on peak) as IOR " +
                              std::to_string(g->ior) +
                              " times maps/gltf_specular.png; the lobes' tails and glTF's "
                              "Fresnel differ");
}

Image LafortuneEquivalentExponent(const MaterialMaps& m) {
  if (m.lobe_shape.channels() < 2) return {};
  Image e(m.width, m.height, 1);
  for (int64_t p = 0; p < e.plane_size(); ++p) e.Plane(0)[p] = 4 * m.lobe_shape.Plane(1)[p];
  return e;
}

void LobeGltf(GltfMaterialDesc* g) {
  g->metallic_roughness_uri = "maps/metallic_roughness.png";
  g->specular_factor = 1.0;
}

}  // namespace model_impl
}  // namespace matfit
