// The registry: every shading model, in ShadingModel order (material.frag's u_model).
// Adding a model: its descriptor file in core/model/, an enumerator in ShadingModel
// (core/material_maps.h), and one line in each list below.
#include <string>

#include "core/check.h"
#include "core/model/model.h"

namespace matfit {
namespace model_impl {
const ModelDescriptor& MeanDescriptor();
const ModelDescriptor& LambertDescriptor();
const ModelDescriptor& BlinnPhongDescriptor();
const ModelDescriptor& CookTorranceDescriptor();
const ModelDescriptor& HeinrichDescriptor();
const ModelDescriptor& PtmDescriptor();
const ModelDescriptor& HshDescriptor();
const ModelDescriptor& LafortuneDescriptor();
const ModelDescriptor& RbfDescriptor();
}  // namespace model_impl

const std::vector<const ModelDescriptor*>& AllModels() {
  using namespace model_impl;
  static const std::vector<const ModelDescriptor*> all = [] {
    std::vector<const ModelDescriptor*> v = {
        &MeanDescriptor(),         &LambertDescriptor(),   &BlinnPhongDescriptor(),
        &CookTorranceDescriptor(), &HeinrichDescriptor(),  &PtmDescriptor(),
        &HshDescriptor(),          &LafortuneDescriptor(), &RbfDescriptor()};
    for (size_t i = 0; i < v.size(); ++i) MATFIT_CHECK(int(v[i]->id()) == int(i));
    return v;
  }();
  return all;
}

const ModelDescriptor& Model(ShadingModel id) {
  const auto& all = AllModels();
  MATFIT_CHECK(int(id) >= 0 && size_t(id) < all.size());
  return *all[size_t(id)];
}

bool HasRtiBasis(ShadingModel id, std::string_view basis) {
  const char* b = Model(id).rti_basis();
  return b != nullptr && basis == b;
}

const ModelDescriptor* FindModel(std::string_view name) {
  for (const ModelDescriptor* m : AllModels())
    if (name == m->name()) return m;
  return nullptr;
}

ShadingModel ModelId(std::string_view name) {
  const ModelDescriptor* m = FindModel(name);
  MATFIT_CHECK(m != nullptr);
  return m->id();
}

}  // namespace matfit
