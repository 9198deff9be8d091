#include "core/material_maps.h"

#include "core/model/model.h"

namespace matfit {

const char* ShadingModelName(ShadingModel m) { return Model(m).name(); }

}  // namespace matfit
