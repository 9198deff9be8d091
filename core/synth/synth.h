// `matfit synth`: a procedural material rendered under a light set with optional
// perturbations, written as a dataset plus truth/ (maps + params.json).
#pragma once

#include "core/progress_fn.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/material_maps.h"
#include "core/synth/perturb.h"

namespace matfit::synth {

struct SynthOptions {
  std::string material = "plaster";  // see Materials()
  std::string lights = "bonn81";     // see light_sets.h
  int size = 64;                     // texels per side (the width), [4, 8192]
  int height = 0;                    // rows, [4, 8192]; 0 = size (square)
  bool shadows = false;              // cast shadows from the height field (always on for fabrics)
  // Near (point) lights: each light at this distance (texels) from the image centre along its
  // direction, lighting each texel along its own direction with 1/r² fall-off; the dataset gets
  // light_positions.txt. 0 = distant lights. Cast shadows still use the nominal direction.
  double near_lights = 0;
  PerturbOptions perturb;         // noise, shot noise, clipping, misregistration
  uint64_t seed = 1;              // everything is a function of the seed
  Layout layout = Layout::kBonn;  // output layout
  int bits = 16;                  // 8 (sRGB PNG), 16 (linear PNG), 32 (EXR)
  std::string format = "auto";    // image files: auto, png, jpg (8-bit), exr (writer.h)
  // Views (a multi-view BTF, bonn/utia layouts): "" = the frontal view only; else a light-set
  // name (light_sets.h: bonn81, dome:N, …) whose directions are the camera directions. Every
  // view × light is rendered rectified to the reference plane (render_views.h): parallax and
  // masking from the height field, cast shadows, Fresnel and Smith masking of the model.
  std::string views;

  int rows() const { return height > 0 ? height : size; }

  bool Check(std::string* why) const;
};

struct MicroSurface;  // micro_geometry.h

struct SynthResult {
  MaterialMaps truth;
  // Micro-geometry materials (MaterialInfo::micro_geometry): the surface the stack was rendered
  // from, whose RenderMicroStack is the relighting truth (`truth` holds normal and albedo only).
  std::shared_ptr<const MicroSurface> micro_surface;
  LightStack stack;       // perturbed, linear, as it will be written (before quantisation)
  PerturbRecord perturb;  // what the perturbations did
  bool cast_shadows = false;
  std::string params_json;  // truth/params.json contents
  std::vector<Vec3> views;  // SynthOptions::views: the camera directions, in stack order
};

// `material` (Materials()) at width × height texels under `lights`, noise-free: its truth maps
// and stack, with cast shadows when `shadows` or the material shadows itself; micro-geometry
// materials through their surface (kept in micro_surface). Pure computation.
struct RenderedMaterial {
  MaterialMaps truth;
  LightStack stack;
  std::shared_ptr<const MicroSurface> micro_surface;
  bool cast_shadows = false;
};
StatusOr<RenderedMaterial> RenderMaterial(const std::string& material, int width, int height,
                                          uint64_t seed, const std::vector<LightSample>& lights,
                                          bool shadows, const ProgressFn& progress = {});

// Pure computation (no I/O).
// `progress` (optional, display only): images rendered.
StatusOr<SynthResult> Synthesize(const SynthOptions& options, const ProgressFn& progress = {});

// Writes dataset + truth/ atomically to `out_dir` (fails if it exists unless overwrite).
Status WriteSynthDataset(const SynthResult& result, const SynthOptions& options,
                         // `progress` (optional, display only): images written.
                         const std::string& out_dir, bool overwrite,
                         const ProgressFn& progress = {});

}  // namespace matfit::synth
