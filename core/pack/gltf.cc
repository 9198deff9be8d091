#include "core/pack/gltf.h"

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/version.h"

namespace matfit {
namespace {

template <typename T>
void Append(std::vector<uint8_t>* bin, const T* data, size_t count) {
  const auto* p = reinterpret_cast<const uint8_t*>(data);
  bin->insert(bin->end(), p, p + count * sizeof(T));
}

}  // namespace

std::string MakeQuadGltf(const GltfMaterialDesc& m, const std::string& bin_uri,
                         std::vector<uint8_t>* bin) {
  using nlohmann::json;
  const float hx = float(m.width_m / 2), hy = float(m.height_m / 2);
  // Quad in the XY plane facing +Z (glTF is Y-up). UV (0,0) = top-left of the image.
  const float pos[12] = {-hx, hy, 0, hx, hy, 0, hx, -hy, 0, -hx, -hy, 0};
  const float nz = m.normals_back ? -1.0f : 1.0f;
  const float nrm[12] = {0, 0, nz, 0, 0, nz, 0, 0, nz, 0, 0, nz};
  const float tan[16] = {1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1};
  const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  const uint16_t idx[6] = {0, 3, 2, 0, 2, 1};  // counter-clockwise seen from +Z
  bin->clear();
  Append(bin, pos, 12);
  Append(bin, nrm, 12);
  Append(bin, tan, 16);
  Append(bin, uv, 8);
  Append(bin, idx, 6);
  bin->resize((bin->size() + 3) / 4 * 4, 0);

  json images = json::array(), textures = json::array();
  auto add_texture = [&](const std::string& uri) {
    images.push_back({{"uri", uri}, {"mimeType", "image/png"}});
    textures.push_back({{"source", int(images.size()) - 1}, {"sampler", 0}});
    return int(textures.size()) - 1;
  };
  json mat = {
      {"name", m.name},
      {"pbrMetallicRoughness",
       {{"baseColorTexture", {{"index", add_texture(m.base_color_uri)}}},
        {"baseColorFactor", {m.base_color_factor, m.base_color_factor, m.base_color_factor, 1.0}},
        {"metallicFactor", 0.0},
        {"roughnessFactor", m.roughness}}}};
  if (!m.metallic_roughness_uri.empty()) {
    mat["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {
        {"index", add_texture(m.metallic_roughness_uri)}};
    mat["pbrMetallicRoughness"]["roughnessFactor"] = 1.0;
  }
  json used = json::array();
  if (!m.normal_uri.empty()) mat["normalTexture"] = {{"index", add_texture(m.normal_uri)}};
  json spec = {{"specularFactor", m.specular_factor}};
  if (!m.specular_color_uri.empty())
    spec["specularColorTexture"] = {{"index", add_texture(m.specular_color_uri)}};
  mat["extensions"]["KHR_materials_specular"] = spec;
  used.push_back("KHR_materials_specular");
  if (m.ior > 0) {
    mat["extensions"]["KHR_materials_ior"] = {{"ior", m.ior}};
    used.push_back("KHR_materials_ior");
  }
  if (!m.diffuse_transmission_uri.empty()) {
    const int tex = add_texture(m.diffuse_transmission_uri);
    mat["extensions"]["KHR_materials_diffuse_transmission"] = {
        {"diffuseTransmissionFactor", 1.0},
        {"diffuseTransmissionTexture", {{"index", tex}}},
        {"diffuseTransmissionColorFactor", {1.0, 1.0, 1.0}},
        {"diffuseTransmissionColorTexture", {{"index", tex}}}};
    used.push_back("KHR_materials_diffuse_transmission");
  }
  if (!m.emissive_uri.empty()) {
    mat["emissiveTexture"] = {{"index", add_texture(m.emissive_uri)}};
    mat["emissiveFactor"] = {1.0, 1.0, 1.0};
  }
  if (m.double_sided) mat["doubleSided"] = true;
  if (m.alpha_mask) mat["alphaMode"] = "MASK", mat["alphaCutoff"] = 0.5;
  json attributes = {{"POSITION", 0}, {"NORMAL", 1}, {"TANGENT", 2}, {"TEXCOORD_0", 3}};
  json g = {
      {"asset", {{"version", "2.0"}, {"generator", std::string("matfit ") + kMatfitVersion}}},
      {"extensionsUsed", used},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", m.name}}}},
      {"meshes",
       {{{"name", m.name},
         {"primitives", {{{"attributes", attributes}, {"indices", 4}, {"material", 0}}}}}}},
      {"materials", {mat}},
      {"samplers",
       {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}}},
      {"images", images},
      {"textures", textures},
      {"buffers", {{{"uri", bin_uri}, {"byteLength", bin->size()}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 48}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 64}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", 160}, {"byteLength", 32}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", 192}, {"byteLength", 12}, {"target", 34963}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {-hx, -hy, 0}},
         {"max", {hx, hy, 0}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC4"}},
        {{"bufferView", 3}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 4}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
  };
  return g.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace matfit
