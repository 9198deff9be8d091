// Lambert (METHODS.md §3): R = ρ_c max(0, n·l). Maps: normal, albedo.
#include "core/model/model_impl.h"

namespace matfit::model_impl {
namespace {

class LambertModel final : public ModelBase<LambertModel> {
 public:
  ShadingModel id() const override { return ShadingModel::kLambert; }
  const char* name() const override { return "lambert"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps&) const override {
    return {};
  }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f&) const override {
    return shading::Lambert(m.albedo.Plane(c)[i], NormalAt(m, i), l);
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    LambertRun(DiffusePlanes(m, p0), light.l, n, channels, out);
  }
  Status WritePackMaps(const MaterialMaps&, const PutPackMapFn&) const override {
    return Status::Ok();
  }
  Status ReadPackMaps(const LoadPackMapFn&, const std::map<std::string, double>&,
                      MaterialMaps*) const override {
    return Status::Ok();
  }
  bool AddShaderPlanes(const MaterialMaps&, ShaderPlaneSink*) const override { return true; }
  bool synthesizable() const override { return true; }
};

}  // namespace

const ModelDescriptor& LambertDescriptor() {
  static const LambertModel model;
  return model;
}

}  // namespace matfit::model_impl
