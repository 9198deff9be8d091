// The GLSL files of render/shaders, embedded at build time (render/embed_shaders.cmake).
#pragma once

#include <string>

namespace matfit::render {

// preamble.glsl + shading.glsl + material.frag, and preamble.glsl + fullscreen.vert: the exact
// text the web viewer assembles from the same files.
std::string MaterialFragmentShader();
std::string FullscreenVertexShader();

}  // namespace matfit::render
