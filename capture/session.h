// A capture session: a plan (which LEDs, exposure brackets, gain, repeats, dark frames, flat
// field) run on a camera + light rig, writing a `.lp` dataset that `matfit fit` reads without
// options, plus capture.json with every setting and per-image record. Images are written as
// linear float EXR, each atomically, and capture.json after each one, so an interrupted
// capture resumes where it stopped (same plan, same devices) and nothing is half-written.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "capture/camera.h"
#include "capture/hdr.h"

namespace matfit::capture {

struct CapturePlan {
  std::vector<int> leds;            // empty = every LED of the rig, in order
  std::vector<double> exposures_s;  // bracket (≥ 1), seconds
  double gain = 1;
  int repeats = 1;         // frames averaged per exposure
  int dark_frames = 0;     // per exposure, all LEDs off; 0 = no dark subtraction
  double level = 1;        // LED level in (0, 1]
  std::string flat_field;  // a flat-field EXR (from `matfit capture --flat-field`), or empty
  bool has_format = false;
  FrameFormat format;
  int timeout_ms = 5000;
  HdrOptions hdr;
  std::string source;  // the plan file (relative paths are resolved against its folder)

  bool Check(std::string* why) const;
};

// Reads a plan file (JSON, schema in docs/capture.md); errors name the file and field.
StatusOr<CapturePlan> ReadPlan(const std::string& path);

struct CaptureResult {
  int images = 0, resumed = 0;  // written now / found done from an earlier run
  int64_t saturated_pixels = 0;
  std::string out;
};

// progress(done, total) after each image; false cancels (the capture can be resumed).
using CaptureProgress = std::function<bool(int done, int total)>;

// overwrite: start again even if `out` holds a different or finished capture.
StatusOr<CaptureResult> RunCapture(Camera& camera, LightRig& rig, const CapturePlan& plan,
                                   const std::string& out, bool overwrite,
                                   const CaptureProgress& progress = {});

// Flat field: every LED at plan.level on a uniform white target, the bracket merged,
// normalised to mean 1, written to `out` (EXR).
Status CaptureFlatField(Camera& camera, LightRig& rig, const CapturePlan& plan,
                        const std::string& out);

}  // namespace matfit::capture
