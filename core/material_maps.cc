#include "core/material_maps.h"

namespace matfit {

const char* ShadingModelName(ShadingModel m) {
  switch (m) {
    case ShadingModel::kMean: return "mean";
    case ShadingModel::kLambert: return "lambert";
    case ShadingModel::kBlinnPhong: return "blinn-phong";
    case ShadingModel::kCookTorrance: return "cook-torrance";
    case ShadingModel::kHeinrich: return "heinrich";
    case ShadingModel::kPtm: return "ptm";
    case ShadingModel::kHsh: return "hsh";
    case ShadingModel::kLafortune: return "lafortune";
  }
  return "?";
}

}  // namespace matfit
