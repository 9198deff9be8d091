// A textured quad as glTF 2.0 (JSON + one binary buffer), for material packs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace matfit {

struct GltfMaterialDesc {
  std::string name;
  std::string base_color_uri;          // sRGB PNG
  double base_color_factor = 1.0;      // baseColorFactor (rgb; alpha 1)
  std::string normal_uri;              // empty: no normal map
  std::string specular_color_uri;      // KHR_materials_specular colour texture; empty: none
  double specular_factor = 1.0;        // KHR_materials_specular specularFactor (0 = no specular)
  double roughness = 1.0;              // pbrMetallicRoughness roughnessFactor
  std::string metallic_roughness_uri;  // G = roughness, B = metallic (0); empty: factor only
  double ior = 0;                      // KHR_materials_ior; 0 = not written
  // Thin two-sided sheets (leaves): KHR_materials_diffuse_transmission from an RGBA texture
  // (RGB = transmission colour, A = transmission factor); empty: none.
  std::string diffuse_transmission_uri;
  // Emission (sRGB texture × emissiveFactor 1): what a model adds independently of the light's
  // direction at unit light (heinrich's ambient term); empty: none.
  std::string emissive_uri;
  // What the glTF approximates of the fit, for material.json ("gltf_approximations").
  std::vector<std::string> approximations;
  // The quad's normals point to −Z while its faces still face +Z (the viewer): lit from behind
  // only, as light crossing a thin sheet (the leaf fallback, material_backlit.gltf).
  bool normals_back = false;
  bool double_sided = false;
  bool alpha_mask = false;               // alphaMode MASK on the base colour's alpha (cutoff 0.5)
  double width_m = 0.1, height_m = 0.1;  // quad size in metres
};

// Returns the .gltf JSON; *bin receives the buffer, referenced as `bin_uri`.
std::string MakeQuadGltf(const GltfMaterialDesc& material, const std::string& bin_uri,
                         std::vector<uint8_t>* bin);

}  // namespace matfit
