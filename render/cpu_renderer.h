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

// The leaf pack previews (`matfit leaf`, the server's leaf jobs): the plane lit from the front
// (θ 30°) or from behind (θ 150°: the light passes through the leaf toward the camera), φ 45°,
// ambient 0.02, size × size pixels; the plane keeps the crop's aspect ratio.
StatusOr<Image> RenderLeafPreview(const MaterialMaps& maps, bool from_behind, int size);

}  // namespace matfit::render
