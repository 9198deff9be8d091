// CPU reference renderer: the preview scenes evaluated per pixel with the shared CPU shading code
// (EvaluateTexel), the ground truth the EGL and WebGL renderers are compared with.
#pragma once

#include "core/image.h"
#include "core/material_maps.h"
#include "core/status.h"
#include "render/render_options.h"

namespace matfit::render {

// RGBA float image (row 0 = top): display-encoded [0, 1] or linear radiance per o.display;
// alpha 1 on the material, 0 on background or masked texels.
StatusOr<Image> RenderCpu(const MaterialMaps& maps, const RenderOptions& o);

}  // namespace matfit::render
