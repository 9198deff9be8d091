// `matfit calibrate-lights`: light directions from a mirror sphere, either a separate chrome set
// with a mask, or one or more spheres inside the capture photos themselves (--sphere).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <regex>

#include "app/commands.h"
#include "capture/calibrate.h"
#include "capture/near_light.h"
#include "capture/sphere_detect.h"
#include "core/atomic_file.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/output_marker.h"
#include "core/progress.h"

namespace matfit::app {
namespace {

namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string dir, mask, out, format = "auto";
  std::vector<std::string> spheres;  // "auto" or "X,Y,R" each
  double focal_px = 0, highlight_fraction = 0.5;
  bool perspective = false, quiet = false, force = false;
  bool distant_lights = false;  // several spheres: mean directions, no positions
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
        ext != ".jpg" && ext != ".jpeg")
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

// "X,Y,R" in pixels (x right, y down, the top-left pixel's centre at 0,0).
bool ParseSphere(const std::string& s, double* x, double* y, double* r) {
  char tail = 0;
  return std::sscanf(s.c_str(), "%lf,%lf,%lf%c", x, y, r, &tail) == 3 && std::isfinite(*x) &&
         std::isfinite(*y) && *r > 0;
}

// The spheres of the photo set: every "auto" detected, every X,Y,R refined on the photos' mean
// (kept as given when no clear edge is found there). 0, or Fail()'s code.
int FindSpheres(const CalibrateArgs& a, const std::vector<std::string>& images,
                std::vector<capture::SphereFit>* spheres) {
  capture::SphereEvidence ev;
  {
    ProgressReporter progress(
        "reading photos", stderr,
        a.quiet ? ProgressReporter::Style::kQuiet : ProgressReporter::Style::kAuto);
    for (size_t i = 0; i < images.size(); ++i) {
      auto img = ReadImage(images[i]);
      if (!img.ok()) return Fail("calibrate-lights", img.status().message().c_str());
      if (Status st = ev.Add(*img); !st.ok())
        return Fail("calibrate-lights", (images[i] + ": " + st.message()).c_str());
      progress.Update(int64_t(i + 1), int64_t(images.size()));
    }
  }
  int autos = 0;
  for (const auto& s : a.spheres) {
    if (s == "auto") {
      ++autos;
      continue;
    }
    double x, y, r;
    if (!ParseSphere(s, &x, &y, &r))
      return Fail("calibrate-lights",
                  ("--sphere '" + s + "' is not auto or X,Y,R (pixels, e.g. 812,604,95)").c_str());
    auto fit = capture::RefineSphere(ev.mean, x, y, r);
    if (fit.ok()) {
      spheres->push_back(*fit);
    } else {
      if (!a.quiet)
        std::printf("sphere      %s kept as given: %s\n", s.c_str(),
                    fit.status().message().c_str());
      spheres->push_back({x, y, r, 0});
    }
  }
  if (autos > 0) {
    capture::SphereDetectOptions o;
    o.spheres = autos;
    auto found = capture::DetectSpheres(ev, o);
    if (!found.ok())
      return Fail("calibrate-lights", (a.dir + ": " + found.status().message()).c_str());
    spheres->insert(spheres->end(), found->begin(), found->end());
  }
  for (size_t i = 0; i < spheres->size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (std::hypot((*spheres)[i].cx - (*spheres)[j].cx, (*spheres)[i].cy - (*spheres)[j].cy) <
          (*spheres)[i].radius + (*spheres)[j].radius)
        return Fail("calibrate-lights", "two of the spheres overlap; give each sphere once");
  return 0;
}

int RunCalibrate(CalibrateArgs a) {
  if (!(a.highlight_fraction > 0 && a.highlight_fraction < 1))
    return Fail("calibrate-lights", "--highlight-fraction must be in (0, 1)");
  if (Status st = CheckOutput(a.out, a.force); !st.ok())
    return Fail("calibrate-lights", st.message().c_str());
  auto images = SphereImages(a.dir, &a.mask);
  if (images.empty()) return Fail("calibrate-lights", ("no images in '" + a.dir + "'").c_str());
  std::vector<capture::SphereFit> spheres;
  int width = 0, height = 0;
  if (!a.spheres.empty()) {
    if (int rc = FindSpheres(a, images, &spheres); rc != 0) return rc;
  } else {
    if (a.mask.empty())
      return Fail("calibrate-lights",
                  ("no sphere mask in '" + a.dir +
                   "' (a file with 'mask' in its name); pass --mask FILE, or --sphere auto for a "
                   "sphere inside the photos")
                      .c_str());
    ImageReadOptions lin;
    lin.color_space = ColorSpaceChoice::kLinear;
    auto mask = ReadImage(a.mask, lin);
    if (!mask.ok()) return Fail("calibrate-lights", mask.status().message().c_str());
    auto sphere = capture::FitSphere(*mask);
    if (!sphere.ok())
      return Fail("calibrate-lights", (a.mask + ": " + sphere.status().message()).c_str());
    spheres.push_back(*sphere);
    width = mask->width(), height = mask->height();
  }
  capture::SphereCalibrationOptions o;
  o.perspective = a.perspective, o.focal_px = a.focal_px;
  o.highlight_fraction = a.highlight_fraction;
  if (!a.quiet)
    for (const auto& s : spheres)
      std::printf("sphere      centre (%.2f, %.2f) px, radius %.2f px (edge rms %.2f px)\n", s.cx,
                  s.cy, s.radius, s.rms_px);
  std::string format = a.format;
  if (format == "auto") format = fs::path(a.out).extension() == ".lp" ? "lp" : "lights-txt";
  if (format != "lp" && format != "lights-txt")
    return Fail("calibrate-lights", "--format must be lp or lights-txt");
  // Two or more spheres (orthographic camera): each light's position, triangulated from the
  // rays the spheres reflect it along (capture/near_light.h); all or none.
  const bool positions = spheres.size() >= 2 && !a.distant_lights && !a.perspective;
  std::vector<capture::TriangulatedLight> placed;
  std::string not_placed;
  std::string text = std::to_string(images.size()) + "\n";
  std::vector<std::string> lines;
  double spread_sum = 0, spread_max = 0;
  for (const auto& f : images) {
    auto img = ReadImage(f);
    if (!img.ok()) return Fail("calibrate-lights", img.status().message().c_str());
    if (width > 0 && (img->width() != width || img->height() != height))
      return Fail("calibrate-lights", (f + " and the mask differ in size").c_str());
    // One direction per sphere; distant lights: their mean (the spheres' disagreement is the
    // near-light parallax, reported below).
    Vec3 sum{0, 0, 0};
    std::vector<Vec3> seen;
    std::string where;
    for (const auto& s : spheres) {
      auto l = capture::EstimateLight(*img, s, o);
      if (!l.ok()) return Fail("calibrate-lights", (f + ": " + l.status().message()).c_str());
      seen.push_back(l->direction);
      sum = {sum.x + l->direction.x, sum.y + l->direction.y, sum.z + l->direction.z};
      char buf[96];
      std::snprintf(buf, sizeof buf, "%s(%.2f, %.2f) %d px", where.empty() ? "" : ", ", l->hx,
                    l->hy, l->pixels);
      where += buf;
    }
    Vec3 d = Normalize(sum);
    if (positions && not_placed.empty()) {
      std::vector<capture::SphereRay> rays;
      for (size_t k = 0; k < spheres.size(); ++k)
        rays.push_back(capture::RayFromSphere(spheres[k], img->width(), img->height(), seen[k]));
      auto p = capture::TriangulateLight(rays);
      if (p.ok()) {
        placed.push_back(*p);
        d = Normalize(p->position);  // as seen from the image centre
      } else {
        not_placed = fs::path(f).filename().string() + ": " + p.status().message();
      }
    }
    for (size_t i = 0; i < seen.size(); ++i)
      for (size_t j = 0; j < i; ++j) {
        const double s = capture::AngleDeg(seen[i], seen[j]);
        spread_sum += s, spread_max = std::max(spread_max, s);
      }
    char line[512];
    if (format == "lp")
      std::snprintf(line, sizeof line, "%s %.6f %.6f %.6f\n",
                    fs::path(f).filename().string().c_str(), d.x, d.y, d.z);
    else
      std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", d.x, d.y, d.z);
    lines.push_back(line);
    if (!a.quiet) {
      std::printf("%-24s highlight %s → (%.4f, %.4f, %.4f)",
                  fs::path(f).filename().string().c_str(), where.c_str(), d.x, d.y, d.z);
      if (positions && not_placed.empty() && !placed.empty())
        std::printf(" at (%.1f, %.1f, %.1f) px, rays %.2f px apart", placed.back().position.x,
                    placed.back().position.y, placed.back().position.z, placed.back().rms);
      std::printf("\n");
    }
  }
  const bool write_positions = positions && not_placed.empty();
  if (positions && !not_placed.empty()) {
    return Fail("calibrate-lights",
                ("near-light positions could not be placed: " + not_placed +
                 "; pass --distant-lights to write the spheres' mean directions instead")
                    .c_str());
  }
  for (const std::string& l : lines) text += l;
  if (spheres.size() > 1) {
    const double pairs = double(images.size() * spheres.size() * (spheres.size() - 1) / 2);
    std::printf("spheres     agree within %.2f° mean, %.2f° max%s\n", spread_sum / pairs,
                spread_max,
                spread_sum / pairs > 1.0 && !write_positions
                    ? ": the lights are near (each sphere sees its own direction); the file "
                      "holds their mean, a distant-light approximation"
                    : "");
  }
  // After the lights, where light-file readers stop: how --force knows matfit wrote the file.
  text += std::string(kTextOutputTrailer) + " calibrate-lights\n";
  const std::string positions_file =
      (fs::path(a.out).parent_path() / "light_positions.txt").string();
  // A light_positions.txt beside the light file would override these directions when the set
  // is read (docs/formats.md): replaced when positions are written, else removed (--force, a
  // file matfit wrote) or refused.
  std::error_code ec;
  if (fs::exists(positions_file, ec)) {
    if (Status st = CheckOutput(positions_file, a.force, "light_positions.txt"); !st.ok())
      return Fail("calibrate-lights", (st.message() + " (it would give the lights written to " +
                                       a.out + " positions: remove it, or pass --force)")
                                          .c_str());
  }
  if (Status st = WriteFileAtomic(a.out, text); !st.ok())
    return Fail("calibrate-lights", st.message().c_str());
  if (write_positions) {
    std::vector<Vec3> at;
    double rms = 0, nearest = INFINITY;
    for (const auto& p : placed) {
      at.push_back(p.position);
      rms = std::max(rms, p.rms), nearest = std::min(nearest, Length(p.position));
    }
    const std::string pos =
        FormatLightPositions(at) + std::string(kTextOutputTrailer) + " calibrate-lights\n";
    if (Status st = WriteFileAtomic(positions_file, pos); !st.ok())
      return Fail("calibrate-lights", st.message().c_str());
    std::printf(
        "positions   %s (%zu near lights, nearest %.1f px from the image centre, rays "
        "within %.2f px)\n",
        positions_file.c_str(), placed.size(), nearest, rms);
  } else if (fs::exists(positions_file, ec) && !fs::remove(positions_file, ec)) {
    return Fail("calibrate-lights", ("cannot remove " + positions_file + ": " + ec.message() +
                                     "; remove it, or its positions override " + a.out)
                                        .c_str());
  }
  std::printf("lights      %s (%zu directions, %s)\n", a.out.c_str(), images.size(),
              format.c_str());
  return 0;
}

}  // namespace

void RegisterCalibrateLights(CLI::App& app, int* exit_code) {
  auto cal = std::make_shared<CalibrateArgs>();
  CLI::App* c = app.add_subcommand(
      "calibrate-lights",
      "Light directions from a mirror sphere: a chrome set with a mask, or spheres in the photos");
  c->add_option("DIR", cal->dir, "folder of sphere images (and a *mask* image), or the capture")
      ->required();
  c->add_option("--mask", cal->mask, "sphere mask (white = sphere), default: DIR/*mask*");
  c->add_option("--sphere", cal->spheres,
                "a reflective sphere inside the photos: auto (found) or X,Y,R in pixels "
                "(refined); repeat for several spheres (no mask needed)");
  c->add_option("--out", cal->out, "light file to write (.lp or lights.txt)")->required();
  c->add_option("--format", cal->format, "auto (from --out), lp or lights-txt")
      ->capture_default_str();
  c->add_flag("--perspective", cal->perspective,
              "perspective camera (needs --focal-px; directions only, no positions)");
  c->add_flag("--distant-lights", cal->distant_lights,
              "with several spheres: write their mean directions, not near-light positions");
  c->add_option("--focal-px", cal->focal_px, "focal length in pixels (perspective)");
  c->add_option("--highlight-fraction", cal->highlight_fraction,
                "pixels within this fraction of the peak form the highlight")
      ->capture_default_str();
  c->add_flag("--force", cal->force, kForceHelp);
  c->add_flag("--quiet", cal->quiet, "only the summary line");
  c->callback([cal, exit_code] { *exit_code = RunCalibrate(*cal); });
}

}  // namespace matfit::app
