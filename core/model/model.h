// ModelDescriptor: the single registration of a shading model. Everything that depends on which
// model a MaterialMaps holds — forward evaluation (per sample and batched), the pack layout
// (maps, material.json parameters, glTF mapping), the shaders' parameter planes and the
// synthetic-truth maps — is a method here, implemented in the model's own file under
// core/model/ and listed once in core/model/registry.cc. Code elsewhere asks the descriptor
// (Model(maps.model)) instead of switching on ShadingModel.
//
// Forward evaluation is defined by the templated CPU shading functions (core/shading/shading.h);
// both evaluators here call them, so fitters, synthetic data and renderers agree by construction.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/material_maps.h"
#include "core/status.h"
#include "core/vec3.h"

namespace matfit {

struct GltfMaterialDesc;

// One light's evaluation constants, computed once per light by Prepare (light-dependent work
// hoisted out of the texel loop): unit light l, view v and half vector h; the relighting
// basis values B_j(l) for ptm/hsh.
struct ModelLight {
  static constexpr int kMaxBasis = 16;
  Vec3f l{0, 0, 1}, v{0, 0, 1}, h{0, 0, 1};
  float basis[kMaxBasis] = {};
};

// How a pack map is stored (core/pack/pack_writer.cc turns it into an image format).
enum class MapEncoding { kSrgb8, kLinear8, kLinear16, kFloat };

// One map for the pack writer: maps/<file>, listed in material.json with its semantic.
struct PackMap {
  const char* name;
  const char* file;
  const Image* image;  // skipped when empty
  MapEncoding encoding;
  const char* semantic;
};
using PutPackMapFn = std::function<Status(const PackMap&)>;
// Loads the pack map listed as `name` into *out (leaves it empty when the pack has none).
using LoadPackMapFn = std::function<Status(const char* name, Image* out)>;

// Collects the model's shader parameter planes (core/pack/shader_params.h layout) after the
// common normal, albedo and mask planes.
class ShaderPlaneSink {
 public:
  virtual ~ShaderPlaneSink() = default;
  // Appends the first `count` planes of `img`; false (remembering `name`) when the map is absent
  // or not the material's size.
  virtual bool Add(const Image& img, int count, const char* name) = 0;
  virtual void AddOnes() = 0;  // a plane of 1 (an optional map that is absent)
  int terms = 0;               // ptm/hsh coefficients per channel, lafortune lobes
  int coef_channels = 3;
  bool heinrich_specular = false, flat_normal = false;
  bool basis_srgb = false;  // ptm/hsh: the basis sum is sRGB-encoded (MaterialMaps::basis_srgb)
  const Image* basis_table = nullptr;  // rbf: MaterialMaps::basis_table (a separate texture)
};

// A synthetic material's specular parameters at one texel (core/synth/materials.cc).
struct TruthLobe {
  double specular = 0, exponent = 0, roughness = 0;
};

class ModelDescriptor {
 public:
  virtual ~ModelDescriptor() = default;
  virtual ShadingModel id() const = 0;
  virtual const char* name() const = 0;  // material.json model.name

  // --- maps ---------------------------------------------------------------------------
  // The model's own parameter maps beyond normal, albedo and mask (name, map), in pack order.
  virtual std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const = 0;
  // Scalars per texel the maps hold (normal 3 + albedo 3 + the parameter maps' channels).
  int ParameterPlanes(const MaterialMaps& m) const;
  // material.json semantic of the albedo map.
  virtual const char* albedo_semantic() const { return "diffuse albedo"; }
  // The pack has a normal map (a unit surface normal a renderer can use).
  virtual bool writes_normal_map() const { return true; }
  // Truth comparisons: the normal / albedo maps are physical quantities comparable to truth.
  virtual bool has_truth_normal() const { return true; }
  virtual bool has_truth_albedo() const { return true; }

  // --- forward evaluation ---------------------------------------------------------------
  // R for texel `index` (row-major), channel c, unit light l and view v, per unit intensity.
  virtual float Evaluate(const MaterialMaps& m, int64_t index, int c, const Vec3f& l,
                         const Vec3f& v) const = 0;
  // Batched evaluation: Prepare once per light, then EvaluateBatch over runs of texels:
  // out[c · n + t] = R(texel p0 + t, channel c) for t < n, c < channels (1 or 3).
  virtual void Prepare(const MaterialMaps& m, const Vec3f& l, const Vec3f& v,
                       ModelLight* out) const;
  virtual void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                             int channels, float* out) const = 0;
  // Several lights over one run: out[(l · channels + c) · n + t] = EvaluateBatch(lights[l], ...)
  // bit for bit. Models whose texel work is shared between lights (a basis model loads its k
  // coefficient planes once for a group of lights) override it; the default loops over lights.
  virtual void EvaluateLights(const MaterialMaps& m, const ModelLight* lights, int count,
                              int64_t p0, int n, int channels, float* out) const;
  // Lights per EvaluateLights call that pay off (1: no sharing; a group's outputs cost cache).
  virtual int light_group() const { return 1; }
  // Scattered evaluation (per-sample texel, light and view, as a renderer's pixels need):
  // out[c · n + k] = R(texels[k], c, l[k], v[k]) for c < 3.
  virtual void EvaluateSamples(const MaterialMaps& m, const int64_t* texels, const Vec3f* l,
                               const Vec3f* v, int n, float* out) const = 0;

  // --- pack -------------------------------------------------------------------------------
  // Writes the model's maps (after albedo and normal, in material.json order).
  virtual Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const = 0;
  // Model parameters stored in material.json model.parameters beyond the fit's own.
  virtual void PackParameters(const MaterialMaps& m, std::map<std::string, double>* out) const {
    (void)m, (void)out;
  }
  // Loads the model's maps and parameters from a pack; an error names what is missing.
  virtual Status ReadPackMaps(const LoadPackMapFn& load,
                              const std::map<std::string, double>& parameters,
                              MaterialMaps* m) const = 0;
  // Whether the glTF shows the Lambert + GGX surface closest to the fit (core/pack/gltf_bake.h):
  // for relighting bases, whose light dependence no glTF material has.
  virtual bool gltf_baked() const { return false; }
  // The RTI tools' name of the model's light basis when its coefficients are one ("ptm": the
  // PTM polynomial; "hsh": hemispherical harmonics), else nullptr: which exports other tools can
  // open (core/pack/pack_exports.h: PTM files, HSH .rti, the relight web layout).
  virtual const char* rti_basis() const { return nullptr; }
  // The closest standard glTF PBR material: specular, roughness, IOR and their textures
  // (base colour and normal are set by the writer). `status` marks fitted texels (0 = ok).
  virtual void Gltf(const MaterialMaps& m, const std::vector<uint8_t>& status,
                    const std::map<std::string, double>& fit_parameters,
                    GltfMaterialDesc* g) const {
    (void)m, (void)status, (void)fit_parameters, (void)g;
  }

  // --- shaders ----------------------------------------------------------------------------
  // Appends the planes material.frag reads for this model; false when a map is missing.
  virtual bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* sink) const = 0;

  // --- synthetic truth --------------------------------------------------------------------
  // Whether synthetic materials are rendered with this model (truth/params.json model.name).
  virtual bool synthesizable() const { return false; }
  // Allocates the model's truth maps for a w × h material and stores one texel's lobe.
  virtual void InitTruthMaps(int w, int h, MaterialMaps* m) const { (void)w, (void)h, (void)m; }
  virtual void SetTruthTexel(int x, int y, const TruthLobe& lobe, MaterialMaps* m) const {
    (void)x, (void)y, (void)lobe, (void)m;
  }
  // params.json: the lobe's formula ("" for none), the specular map's meaning, and the
  // material-wide parameters (e.g. a shared exponent).
  virtual const char* truth_formula() const { return ""; }
  virtual const char* truth_specular_semantic() const { return ""; }
  virtual void TruthParameters(const MaterialMaps& m, std::map<std::string, double>* out) const {
    (void)m, (void)out;
  }
};

// The registry (core/model/registry.cc).
const ModelDescriptor& Model(ShadingModel id);
const ModelDescriptor* FindModel(std::string_view name);  // nullptr when unknown
// The id of a model known to exist (a programming error otherwise: MATFIT_CHECK).
ShadingModel ModelId(std::string_view name);
const std::vector<const ModelDescriptor*>& AllModels();
// Whether the model's coefficients are the RTI tools' `basis` ("ptm" or "hsh"; rti_basis()).
bool HasRtiBasis(ShadingModel id, std::string_view basis);

// Batched evaluation of a whole map set under a list of lights: the light constants prepared
// once, then runs of texels. Thread-safe for concurrent Evaluate calls.
class BatchEvaluator {
 public:
  BatchEvaluator(const MaterialMaps& maps, const std::vector<Vec3f>& lights, const Vec3f& view);
  // Each light with its own view (a multi-view stack's images): views.size() == lights.size().
  BatchEvaluator(const MaterialMaps& maps, const std::vector<Vec3f>& lights,
                 const std::vector<Vec3f>& views);
  int lights() const { return int(prepared_.size()); }
  // out[c · n + t] for texels [p0, p0 + n), channels c < `channels`, light i.
  void Evaluate(int light, int64_t p0, int n, int channels, float* out) const {
    model_->EvaluateBatch(*maps_, prepared_[size_t(light)], p0, n, channels, out);
  }
  // Lights [first, first + count): out[(l · channels + c) · n + t], the same values as
  // Evaluate(first + l, ...) — faster for models that share texel work between lights, in groups
  // of group() lights (≤ kMaxEvalLightGroup).
  void EvaluateLights(int first, int count, int64_t p0, int n, int channels, float* out) const {
    model_->EvaluateLights(*maps_, prepared_.data() + first, count, p0, n, channels, out);
  }
  int group() const { return model_->light_group(); }

 private:
  const MaterialMaps* maps_;
  const ModelDescriptor* model_;
  std::vector<ModelLight> prepared_;
};

// Texels per run for batched evaluation: long enough to amortise per-run work, short enough
// that a run's parameter planes and outputs stay in L1/L2.
inline constexpr int kEvalRun = 1024;
// The largest light_group() of any model (a basis model keeps four lights' sums in registers
// while it reads each coefficient once): buffers for a group hold this many lights' outputs.
inline constexpr int kMaxEvalLightGroup = 4;

}  // namespace matfit
