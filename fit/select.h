// Model selection, "no more model than the scene needs" (`matfit fit --model auto`).
//
// A scene (scene.json, schema "matfit.scene/1") says how the material will be seen:
//   texel_footprint_px  width of one texel on screen in pixels at the viewing distance (1 = full
//                       resolution; 0.25 = a quarter pixel, 4×4 texels per pixel → mip 2)
//   lighting            "dynamic" (any direction) or "static"
//   light               "directional" (a sun) or "environment" (light from the whole
//                       hemisphere, cosine-weighted)
//   sun_theta_deg, sun_phi_deg   static directional: the sun's direction
//   memory_budget_bytes          0 = unlimited
//   error_budget                 held-out RMSE allowed, > 0, in the error metric's unit
//   view_theta_max_deg           the most oblique camera the renderer shows (θv, degrees, [0, 90];
//                                default 90): of a multi-view BTF (--view all) only the views
//                                up to it are fitted (always the most frontal); one view left
//                                is fitted by the single-view ladder, several by the methods over
//                                views
//   error_metric                 "linear" (RMSE of linear radiance, the default) or "srgb8":
//                                RMS difference of the 8-bit sRGB codes of measurement and
//                                prediction / 255 (what RTI users read as PSNR: 20 log10(1 / e))
// Level L = max(0, floor(log2(1 / footprint))), clamped so ≥ 4 texels per side remain: the
// stack is box-downsampled by 2^L (what the
// renderer shows), and candidates are (model, map resolution 2^-(L+k), k = 0..2). Each is
// scored by k-fold held-out lights at level L — maps fitted at level L+k predict level-L texels
// from their parent texel — weighted for the scene's light: all lights (dynamic), lights near
// the sun (static directional, Gaussian of 15° in angle), or the error of the cosine-weighted
// light average (environment). Candidates are tried from the fewest bytes up; the first that
// meets the error budget (flagging ≤ 1 % of its texels, every fold fitted, each fold's fit
// assessed as in fit/assess.h) and the memory budget wins. Stacks that look gamma-encoded are
// refused (no model would be right).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_types.h"

namespace matfit::fit {

struct SceneSpec {
  double texel_footprint_px = 1;
  bool static_light = false;
  bool environment = false;
  double sun_theta_deg = 0, sun_phi_deg = 0;
  double memory_budget_bytes = 0;
  double view_theta_max_deg = 90;
  double error_budget = 0.02;
  bool srgb8 = false;  // error_metric "srgb8" (else linear)
  std::string source;  // file it came from (for messages)

  bool Check(std::string* why) const;
};

// Parses scene.json text; errors name the field and `source`.
StatusOr<SceneSpec> ParseScene(const std::string& json_text, const std::string& source);

struct SelectOptions {
  std::vector<std::string> methods;  // empty: the whole ladder
  int folds = 3;                     // held-out folds, ≥ 2
  int max_coarser_levels = 2;        // k = 0..this
  FitOptions fit;                    // progress: candidates done / total
};

struct Candidate {
  std::string method;
  int level = 0, width = 0, height = 0;  // map resolution
  int64_t bytes = 0;                     // bytes_per_texel × map texels
  bool evaluated = false;
  double error = NAN;              // scene-weighted held-out RMSE at the scene's level
  double flagged_fraction = 0;     // texels the folds' fits flagged
  double fit_seconds = 0;          // one fit at this resolution (the first fold's)
  double render_ns_per_pixel = 0;  // CPU shading cost of the fitted maps
  bool meets = false;
  std::string note;  // why not chosen / not evaluated
};

struct Selection {
  std::string method;
  int level = 0, scene_level = 0, width = 0, height = 0;
  double error = NAN;
  std::vector<Candidate> candidates;  // in the order tried (fewest bytes first)
  std::string reason;
  std::vector<std::string> warnings;
  bool budget_met = true;  // false: nothing met the budget; the lowest-error candidate is used
  int views = 1, views_in_data = 1;  // views fitted (ScenesViews) of those the stack held
};

// The images of a multi-view stack that the scene shows: the views with θv ≤
// scene.view_theta_max_deg (+0.5° for angles rounded in file names), always the most frontal
// one; a single view as a single-view stack (SelectView). A single-view stack is returned as is.
LightStack ScenesViews(const LightStack& stack, const SceneSpec& scene);

// The mip level the scene shows an image of width × height at (≥ 4 texels per side kept).
int SceneLevel(const SceneSpec& scene, int width, int height);
// Rows per block of the coarsest stack the selection scores on an image of width × height:
// a distributed selection splits the rows in multiples of it (fit/bands.h), so that every
// rank's downsampled band is rows of the whole downsampled stack.
int SelectionRowMultiple(const SceneSpec& scene, int width, int height, const SelectOptions& o);

StatusOr<Selection> SelectModel(const LightStack& stack, const SceneSpec& scene,
                                const SelectOptions& options);

// report.json "selection" object.
std::string SelectionJson(const Selection& s, const SceneSpec& scene);

}  // namespace matfit::fit
