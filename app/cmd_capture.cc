// `matfit capture` and `matfit devices` (capture/); `matfit calibrate-lights` is cmd_calibrate.cc.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "app/commands.h"
#include "capture/registry.h"
#include "capture/session.h"
#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/output_marker.h"
#include "core/progress.h"

namespace matfit::app {
namespace {

namespace fs = std::filesystem;

struct CaptureArgs {
  std::string camera, rig, rig_lights, plan, out;
  bool force = false, flat = false, quiet = false;
};

int RunCapture(const CaptureArgs& a) {
  auto plan = capture::ReadPlan(a.plan);
  if (!plan.ok()) return Fail("capture", plan.status().message().c_str());
  auto cam = capture::OpenCamera(a.camera);
  if (!cam.ok()) return Fail("capture", cam.status().message().c_str());
  auto rig = capture::OpenLightRig(a.rig, a.rig_lights);
  if (!rig.ok()) return Fail("capture", rig.status().message().c_str());
  if (a.flat) {
    if (Status st = CheckOutput(a.out, a.force); !st.ok())
      return Fail("capture", st.message().c_str());
    Status st = capture::CaptureFlatField(**cam, **rig, *plan, a.out);
    if (!st.ok()) return Fail("capture", st.message().c_str());
    std::printf("flat field  %s (mean 1; name it in a plan's \"flat_field\")\n", a.out.c_str());
    return 0;
  }
  std::unique_ptr<ProgressReporter> bar;
  if (!a.quiet) bar = std::make_unique<ProgressReporter>("capture");
  auto r = capture::RunCapture(**cam, **rig, *plan, a.out, a.force, [&](int d, int t) {
    if (bar) bar->Update(d, t);
    return true;
  });
  bar.reset();
  if (!r.ok()) return Fail("capture", r.status().message().c_str());
  std::printf("captured    %d images (%d kept from an earlier run) with %s and %s\n", r->images,
              r->resumed, (*cam)->Info().uri.c_str(), (*rig)->Describe().c_str());
  std::printf("saturated   %lld pixels clipped at every exposure\n",
              (long long)r->saturated_pixels);
  std::printf("dataset     %s (lights.lp + capture.json; `matfit fit %s --model …`)\n",
              a.out.c_str(), a.out.c_str());
  return 0;
}

}  // namespace

void RegisterCapture(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<CaptureArgs>();
  CLI::App* sub = app.add_subcommand(
      "capture", "Acquire a multi-light dataset with a camera and a light rig (a plan file)");
  sub->add_option("--camera", args->camera, "camera URI: v4l2:/dev/videoN or sim:camera?…")
      ->required();
  sub->add_option("--rig", args->rig, "light rig URI: usb:VID:PID[:SERIAL] or sim:rig?…")
      ->required();
  sub->add_option("--rig-lights", args->rig_lights,
                  "the rig's LED directions (.lp or lights.txt); required for usb: rigs");
  sub->add_option("--plan", args->plan, "capture plan (JSON, docs/capture.md)")->required();
  sub->add_option("--out", args->out, "dataset folder (or, with --flat-field, an .exr)")
      ->required();
  sub->add_flag("--force", args->force,
                "start again instead of resuming (replaces only a capture matfit wrote)");
  sub->add_flag("--flat-field", args->flat,
                "capture a flat field (all LEDs on a uniform white target) into --out");
  sub->add_flag("--quiet", args->quiet, "no progress bar");
  sub->callback([args, exit_code] { *exit_code = RunCapture(*args); });

  RegisterCalibrateLights(app, exit_code);  // cmd_calibrate.cc

  CLI::App* d = app.add_subcommand("devices", "List connected cameras and light rigs");
  d->callback([exit_code] {
    for (const auto& line : capture::ListDevices()) std::printf("%s\n", line.c_str());
    *exit_code = 0;
  });
}

}  // namespace matfit::app
