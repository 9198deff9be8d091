// Procedural materials with known per-texel maps (synthetic ground truth).
//   plaster     Lambertian, fBm bumps, off-white
//   plastic     glossy Blinn–Phong (k_s 0.35, e 40), coloured, gentle dents
//   plastic-ct  the same surface with Cook–Torrance GGX (F0 0.04 = IOR 1.5, roughness 0.35)
//   lacquer     Cook–Torrance with F0 (0.03–0.08) and roughness (0.2–0.5) varying per texel
//   wool        plain-weave threads with fuzz; meso-scale self-shadowing; weak sheen
//   corduroy    vertical ridges (wales) with deep grooves; self-shadowing; weak sheen
//   granite     speckled cellular minerals, polished (Blinn–Phong e 128)
//   leaf        veined leaf on a dark background: mask, thickness (mm), translucency,
//               Cook–Torrance upper side (IOR 1.45, roughness 0.35)
//   micro-stone rendered from explicit micro-geometry (micro_geometry.h), not from any fitted
//               model's formula; its maps are the macro normal and albedo only
// Patterns are defined over the unit square, so a size-64 material is a coarser sampling of
// the size-256 one (same slopes, same look).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit::synth {

struct MaterialInfo {
  std::string name, description;
  bool self_shadowing = false;  // cast shadows from the height field are part of the material
  // Its appearance comes from micro-geometry (micro_geometry.h): the maps MakeMaterial gives are
  // its macro normal and albedo, and relighting truth is RenderMicroStack, not the maps' model.
  bool micro_geometry = false;
};

const std::vector<MaterialInfo>& Materials();
const MaterialInfo* FindMaterial(const std::string& name);

// Builds the maps of material `name` at size × size texels.
StatusOr<MaterialMaps> MakeMaterial(const std::string& name, int size, uint64_t seed);
// width × height texels: the top-left crop of the max(width, height)² material (same texel
// scale, normals from the uncropped height field); width == height is the square one.
StatusOr<MaterialMaps> MakeMaterial(const std::string& name, int width, int height, uint64_t seed);

// Unit normals from a height field in texel units: n = normalize(−∂h/∂x, −∂h/∂y, 1), central
// differences with wrap-around, y up (row index grows downward).
Image NormalsFromHeight(const Image& height);

}  // namespace matfit::synth
