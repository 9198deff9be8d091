// Shared by the model files in core/model/ (not for use elsewhere): the CRTP base that derives
// the scattered evaluator from the model's own Evaluate, and the vectorised diffuse run.
#pragma once

#include <algorithm>

#include "core/model/model.h"
#include "core/shading/shading.h"
#include "core/simd_clones.h"

// Hot texel loops are built for the baseline ISA and for AVX2+FMA / AVX-512, picked at load
// time (core/simd_clones.h), like the fit's row kernels.
#define MATFIT_MODEL_CLONES MATFIT_CLONES_V4

namespace matfit::model_impl {

template <typename Derived>
class ModelBase : public ModelDescriptor {
 public:
  void EvaluateSamples(const MaterialMaps& m, const int64_t* texels, const Vec3f* l, const Vec3f* v,
                       int n, float* out) const override {
    const Derived& self = static_cast<const Derived&>(*this);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c)
        out[c * n + k] = self.Derived::Evaluate(m, texels[k], c, l[k], v[k]);
  }
};

inline Vec3f NormalAt(const MaterialMaps& m, int64_t i) {
  return {m.normal.Plane(0)[i], m.normal.Plane(1)[i], m.normal.Plane(2)[i]};
}

// Pointers to the normal and albedo planes at texel p0.
struct DiffusePlanes {
  const float *nx, *ny, *nz, *albedo[3];
  DiffusePlanes(const MaterialMaps& m, int64_t p0) {
    nx = m.normal.Plane(0).data() + p0, ny = m.normal.Plane(1).data() + p0;
    nz = m.normal.Plane(2).data() + p0;
    for (int c = 0; c < 3; ++c) albedo[c] = m.albedo.Plane(c).data() + p0;
  }
};

// out[c · n + t] = shading::Lambert(ρ_c, n_t, l) for a run of n texels.
void LambertRun(const DiffusePlanes& d, const Vec3f& l, int n, int channels, float* out);

// out[c · n + t] += lobe(t) for every channel: the achromatic specular lobes add one value.
template <typename Lobe>
inline void AddLobeRun(int n, int channels, float* out, Lobe&& lobe) {
  for (int t = 0; t < n; ++t) {
    const float s = lobe(t);
    for (int c = 0; c < channels; ++c) out[c * n + t] += s;
  }
}

// The maps of the lobe models in pack order (specular, roughness, exponent, lobe shape) and
// the glTF metallic-roughness texture (G = roughness(p), B = metallic = 0).
Status PutLobeMaps(const MaterialMaps& m, const PutPackMapFn& put, const char* specular_semantic,
                   const Image& metallic_roughness);
Image MetallicRoughness(const MaterialMaps& m, float (*roughness_at)(const MaterialMaps&, int64_t));
// Loads specular, roughness, exponent and lobe_shape where the pack lists them.
Status LoadLobeMaps(const LoadPackMapFn& load, MaterialMaps* m);
// glTF for the lobe models: metallic-roughness texture, specular on.
void LobeGltf(GltfMaterialDesc* g);
// A Phong-type lobe peak · (n·h)^e (exponent plane `exponent`) as glTF's GGX: roughness
// (2/(e+2))^{1/4} and the F0 with the same head-on peak, F0 = 4 α² peak = 8 peak / (e + 2)
// (glTF's specular at n = h = l = v is F0 D(1)/4 per unit irradiance × π, D(1) = 1/(π α²)).
// The material's F0 (99th percentile over texels, at most 0.81) becomes the IOR and each
// texel's share of it maps/gltf_specular.png (specularColorTexture).
Status PutGltfSpecular(const MaterialMaps& m, const Image& peak, const Image& exponent,
                       const PutPackMapFn& put);
void GltfSpecular(const MaterialMaps& m, const Image& peak, const Image& exponent, const char* lobe,
                  GltfMaterialDesc* g);
// A Lafortune lobe's Blinn–Phong-equivalent exponent 4 e, first lobe: seen along the normal
// (v = n), D = n·l = cos α, and D^e ≈ exp(−e α²/2) and (n·h)^{4e} = cos^{4e}(α/2) ≈
// exp(−4e α²/8) have the same peak and curvature.
Image LafortuneEquivalentExponent(const MaterialMaps& m);

}  // namespace matfit::model_impl
