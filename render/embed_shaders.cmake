# cmake -DOUT=file.cc -DDIR=shader_dir -P embed_shaders.cmake: writes the shader sources as C++
# raw strings (delimiter chosen so GLSL cannot end it early).
file(READ "${DIR}/preamble.glsl" PREAMBLE)
file(READ "${DIR}/shading.glsl" SHADING)
file(READ "${DIR}/material.frag" MATERIAL)
file(READ "${DIR}/fullscreen.vert" VERT)
file(WRITE "${OUT}.tmp" "// Generated from render/shaders by render/embed_shaders.cmake; do not edit.
#include \"render/shader_sources.h\"

namespace matfit::render {

std::string MaterialFragmentShader() {
  return std::string(R\"glsl(${PREAMBLE})glsl\") + R\"glsl(${SHADING})glsl\" + R\"glsl(${MATERIAL})glsl\";
}

std::string FullscreenVertexShader() {
  return std::string(R\"glsl(${PREAMBLE})glsl\") + R\"glsl(${VERT})glsl\";
}

}  // namespace matfit::render
")
file(RENAME "${OUT}.tmp" "${OUT}")
