// `matfit capture`, `matfit calibrate-lights`, `matfit devices` (capture/).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <regex>

#include "app/commands.h"
#include "capture/calibrate.h"
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

struct CalibrateArgs {
  std::string dir, mask, out, format = "auto";
  double focal_px = 0, highlight_fraction = 0.1;
  bool perspective = false, quiet = false, force = false;
};

// Images of the folder other than the mask, ordered by the last number in the name.
std::vector<std::string> SphereImages(const std::string& dir, std::string* mask) {
  std::vector<std::pair<long, std::string>> files;
  std::error_code ec;
  static const std::regex num(".*?(\\d+)\\D*$");
  const std::string given_mask =
      mask->empty() ? "" : fs::weakly_canonical(fs::absolute(*mask, ec), ec).string();
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::string n = e.path().filename().string();
    std::transform(n.begin(), n.end(), n.begin(), ::tolower);
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext != ".png" && ext != ".tga" && ext != ".exr" && ext != ".tif" && ext != ".tiff" &&
        ext != ".jpg")
      continue;
    if (!given_mask.empty() &&
        fs::weakly_canonical(fs::absolute(e.path(), ec), ec).string() == given_mask)
      continue;  // the mask named by --mask is not a light image
    if (n.find("mask") != std::string::npos) {
      if (mask->empty()) *mask = e.path().string();
      continue;
    }
    std::smatch m;
    const std::string stem = e.path().stem().string();
    long index = 0;
    if (std::regex_match(stem, m, num) && m[1].length() <= 9) index = std::stol(m[1]);
    files.push_back({index, e.path().string()});
  }
  std::sort(files.begin(), files.end());
  std::vector<std::string> out;
  for (auto& f : files) out.push_back(f.second);
  return out;
}

int RunCalibrate(CalibrateArgs a) {
  if (!(a.highlight_fraction > 0 && a.highlight_fraction < 1))
    return Fail("calibrate-lights", "--highlight-fraction must be in (0, 1)");
  if (Status st = CheckOutput(a.out, a.force); !st.ok())
    return Fail("calibrate-lights", st.message().c_str());
  auto images = SphereImages(a.dir, &a.mask);
  if (images.empty()) return Fail("calibrate-lights", ("no images in '" + a.dir + "'").c_str());
  if (a.mask.empty())
    return Fail("calibrate-lights", ("no sphere mask in '" + a.dir +
                                     "' (a file with 'mask' in its name); pass --mask FILE")
                                        .c_str());
  ImageReadOptions lin;
  lin.color_space = ColorSpaceChoice::kLinear;
  auto mask = ReadImage(a.mask, lin);
  if (!mask.ok()) return Fail("calibrate-lights", mask.status().message().c_str());
  auto sphere = capture::FitSphere(*mask);
  if (!sphere.ok())
    return Fail("calibrate-lights", (a.mask + ": " + sphere.status().message()).c_str());
  capture::SphereCalibrationOptions o;
  o.perspective = a.perspective, o.focal_px = a.focal_px;
  o.highlight_fraction = a.highlight_fraction;
  if (!a.quiet)
    std::printf("sphere      centre (%.2f, %.2f) px, radius %.2f px (boundary rms %.2f px)\n",
                sphere->cx, sphere->cy, sphere->radius, sphere->rms_px);
  std::string format = a.format;
  if (format == "auto") format = fs::path(a.out).extension() == ".lp" ? "lp" : "lights-txt";
  if (format != "lp" && format != "lights-txt")
    return Fail("calibrate-lights", "--format must be lp or lights-txt");
  std::string text = std::to_string(images.size()) + "\n";
  for (const auto& f : images) {
    auto img = ReadImage(f);
    if (!img.ok()) return Fail("calibrate-lights", img.status().message().c_str());
    if (img->width() != mask->width() || img->height() != mask->height())
      return Fail("calibrate-lights", (f + " and the mask differ in size").c_str());
    auto l = capture::EstimateLight(*img, *sphere, o);
    if (!l.ok()) return Fail("calibrate-lights", (f + ": " + l.status().message()).c_str());
    char line[512];
    const Vec3& d = l->direction;
    if (format == "lp")
      std::snprintf(line, sizeof line, "%s %.6f %.6f %.6f\n",
                    fs::path(f).filename().string().c_str(), d.x, d.y, d.z);
    else
      std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", d.x, d.y, d.z);
    text += line;
    if (!a.quiet)
      std::printf("%-24s highlight (%.2f, %.2f), %d px → (%.4f, %.4f, %.4f)\n",
                  fs::path(f).filename().string().c_str(), l->hx, l->hy, l->pixels, d.x, d.y, d.z);
  }
  // After the lights, where light-file readers stop: how --force knows matfit wrote the file.
  text += std::string(kTextOutputTrailer) + " calibrate-lights\n";
  if (Status st = WriteFileAtomic(a.out, text); !st.ok())
    return Fail("calibrate-lights", st.message().c_str());
  std::printf("lights      %s (%zu directions, %s)\n", a.out.c_str(), images.size(),
              format.c_str());
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

  auto cal = std::make_shared<CalibrateArgs>();
  CLI::App* c =
      app.add_subcommand("calibrate-lights", "Light directions from chrome-sphere images (+ mask)");
  c->add_option("DIR", cal->dir, "folder of sphere images and a *mask* image")->required();
  c->add_option("--mask", cal->mask, "sphere mask (white = sphere), default: DIR/*mask*");
  c->add_option("--out", cal->out, "light file to write (.lp or lights.txt)")->required();
  c->add_option("--format", cal->format, "auto (from --out), lp or lights-txt")
      ->capture_default_str();
  c->add_flag("--perspective", cal->perspective, "perspective camera (needs --focal-px)");
  c->add_option("--focal-px", cal->focal_px, "focal length in pixels (perspective)");
  c->add_option("--highlight-fraction", cal->highlight_fraction,
                "pixels within this fraction of the peak form the highlight")
      ->capture_default_str();
  c->add_flag("--force", cal->force, kForceHelp);
  c->add_flag("--quiet", cal->quiet, "only the summary line");
  c->callback([cal, exit_code] { *exit_code = RunCalibrate(*cal); });

  CLI::App* d = app.add_subcommand("devices", "List connected cameras and light rigs");
  d->callback([exit_code] {
    for (const auto& line : capture::ListDevices()) std::printf("%s\n", line.c_str());
    *exit_code = 0;
  });
}

}  // namespace matfit::app
