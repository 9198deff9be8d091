// A material whose appearance is computed from explicit micro-geometry, not from the formula of
// any model matfit fits (issue 19 "truth no model was built from"). Each texel is sub × sub
// micro-facets of a periodic height field; each facet is a Lambertian base under a smooth
// dielectric coat (normalised Phong lobe around the mirror direction, Schlick Fresnel), and a
// texel's reading is the projected-area average over its facets of
//   ρ · (E_l + E_b) + F(n·l) · (e + 2) / 2 · max(0, r·v)^e · E_l,   E_l = max(0, n·l) · V_l,
// with V_l the light's visibility from the facet (ray-traced self-shadowing, through a horizon
// map), facets weighted by V_v · max(0, n·v) / n_z (masking towards the view), and E_b one
// bounce of diffuse inter-reflection: the mean direct diffuse reading of the facets hit by
// cosine-distributed rays from the facet (rays that escape see a black sky). Units are the
// stack's: a flat Lambertian texel of albedo ρ reads ρ · (n·l) under a unit light.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "core/status.h"
#include "core/vec3.h"

namespace matfit::synth {

struct MicroGeometryOptions {
  int sub = 4;                // micro-facets per texel side, [1, 16]
  double bump_height = 0.35;  // micro-bump amplitude, texels (slopes of about 30°)
  double relief = 1.5;        // meso-scale relief amplitude over the sample, texels
  int azimuths = 24;          // horizon-map directions, [8, 64]
  int bounce_rays = 16;       // gather rays per facet, [1, 64]
  double reach_texels = 3;    // how far shadow and bounce rays look, texels
  double ior = 1.5;           // the coat's index of refraction (F0 = 0.04)
  double lobe_exponent = 60;  // the coat's Phong exponent (micro-facet highlight width)
  // Parts of the light transport, for tests: all on for the material.
  bool shadows = true, masking = true, bounce = true, specular = true;

  bool Check(std::string* why) const;
};

struct MicroSurface {
  int width = 0, height = 0;  // texels
  MicroGeometryOptions options;
  int mw = 0, mh = 0;  // micro-facets: width · sub, height · sub
  // Per facet (row-major, row index grows downward): height in facet widths, unit normal
  // (x right, y up, z out of the surface).
  std::vector<float> h, nx, ny, nz;
  std::vector<float> albedo;       // per texel, 3 planes: the facets' diffuse albedo
  std::vector<float> horizon_tan;  // [azimuth][facet]: tangent of the horizon's elevation
  std::vector<int32_t> bounce;     // [ray][facet]: the facet a gather ray hits, −1 = sky

  int64_t facets() const { return int64_t(mw) * mh; }
};

// A stone-like surface: meso-scale fBm relief plus sub-texel bumps, mineral-speckled albedo.
// Deterministic in (width, height, seed, options); precomputes the horizon map and bounce rays.
StatusOr<MicroSurface> MakeMicroSurface(int width, int height, uint64_t seed,
                                        const MicroGeometryOptions& options = {});

// Every texel's reading under a directional light of unit intensity seen from `view` (unit
// vectors, z out of the surface): out[c · texels + p], 3 channels.
void RenderMicroLight(const MicroSurface& s, const Vec3& light, const Vec3& view, float* out);

// A stack of those readings (times each light's intensity); images in parallel.
LightStack RenderMicroStack(const MicroSurface& s, const std::vector<LightSample>& lights,
                            const Vec3& view = {0, 0, 1}, const ProgressFn& progress = {});

// Truth maps for normal and albedo comparisons: model lambert, the macro normal (the texel's
// mean facet slope) and the facets' albedo. Not its appearance: RenderMicroLight is.
MaterialMaps MicroTruthMaps(const MicroSurface& s);

}  // namespace matfit::synth
