// The WebGL2 viewer (render/web) and its GLSL (render/shaders), embedded at build time.
#pragma once

#include <string_view>

namespace matfit::server {

// "index.html", "viewer.js", "preamble.glsl", "shading.glsl", "material.frag",
// "fullscreen.vert"; empty for any other name.
std::string_view WebAsset(std::string_view name);

}  // namespace matfit::server
