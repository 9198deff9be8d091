// Mean: the per-texel mean colour (albedo plane) under every light; no normal.
#include <algorithm>

#include "core/model/model_impl.h"
#include "core/pack/gltf.h"

namespace matfit::model_impl {
namespace {

class MeanModel final : public ModelBase<MeanModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kMean; }
  const char* name() const override { return "mean"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps&) const override {
    return {};
  }
  bool writes_normal_map() const override { return false; }
  bool has_truth_normal() const override { return false; }
  bool has_truth_albedo() const override { return false; }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f&,
                 const Vec3f&) const override {
    return m.albedo.Plane(c)[i];
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight&, int64_t p0, int n, int channels,
                     float* out) const override {
    for (int c = 0; c < channels; ++c) std::copy_n(m.albedo.Plane(c).data() + p0, n, out + c * n);
  }
  Status WritePackMaps(const MaterialMaps&, const PutPackMapFn&) const override {
    return Status::Ok();
  }
  Status ReadPackMaps(const LoadPackMapFn&, const std::map<std::string, double>&,
                      MaterialMaps*) const override {
    return Status::Ok();
  }
  bool AddShaderPlanes(const MaterialMaps&, ShaderPlaneSink*) const override { return true; }
  // The mean is what the sample shows under any light: in glTF, emission (no reflection).
  void Gltf(const MaterialMaps&, const std::vector<uint8_t>&, const std::map<std::string, double>&,
            GltfMaterialDesc* g) const override {
    g->emissive_uri = g->base_color_uri;
    g->base_color_factor = 0.0;
    g->approximations.push_back(
        "the mean model does not depend on the light: the glTF emits the mean texture "
        "(emissiveTexture = maps/albedo.png, baseColorFactor 0), as matfit shows it at unit "
        "light; it does not follow a viewer's light intensity");
  }
};

}  // namespace

const ModelDescriptor& MeanDescriptor() {
  static const MeanModel model;
  return model;
}

}  // namespace matfit::model_impl
