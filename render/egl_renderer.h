// Headless GPU renderer: EGL on a surfaceless Mesa display (llvmpipe here, any GPU driver
// elsewhere), a GLES 3.x context, the shared GLSL (render/shaders) drawn into an RGBA32F
// framebuffer and read back. Create() fails with a clear message, never a crash, when no EGL
// display or no suitable context is available; the CPU renderer still works then.
#pragma once

#include <memory>
#include <string>

#include "core/image.h"
#include "core/material_maps.h"
#include "core/status.h"
#include "render/render_options.h"

namespace matfit::render {

class EglRenderer {
 public:
  static StatusOr<std::unique_ptr<EglRenderer>> Create();
  ~EglRenderer();
  EglRenderer(const EglRenderer&) = delete;
  EglRenderer& operator=(const EglRenderer&) = delete;

  // Same contract as RenderCpu: RGBA float, row 0 = top.
  StatusOr<Image> Render(const MaterialMaps& maps, const RenderOptions& o);
  // "OpenGL ES 3.2 Mesa …, llvmpipe …": what the context runs on.
  std::string Description() const;

 private:
  struct State;
  explicit EglRenderer(std::unique_ptr<State> s);
  std::unique_ptr<State> s_;
};

}  // namespace matfit::render
