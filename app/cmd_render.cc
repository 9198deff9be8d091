// matfit render: preview a material pack under a directional light (one image or a sweep).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "core/image_io.h"
#include "core/output_marker.h"
#include "core/pack/pack_reader.h"
#include "core/parallel.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace matfit::app {
namespace {

struct RenderArgs {
  std::string pack, out, light = "30,45", camera = "0,0", scene = "plane", backend = "auto",
                         tonemap = "clamp";
  render::RenderOptions options;
  int sweep = 0, threads = 0;
  bool quiet = false, force = false;
};

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int RunRender(RenderArgs a) {
  render::RenderOptions& o = a.options;
  SetNumThreads(a.threads);
  if (!ParseViewArg(a.light.c_str(), &o.theta_deg, &o.phi_deg))
    return Fail("render", ("--light wants THETA,PHI in degrees, got '" + a.light + "'").c_str());
  if (!ParseViewArg(a.camera.c_str(), &o.camera_theta_deg, &o.camera_phi_deg))
    return Fail("render", ("--camera wants THETA,PHI in degrees, got '" + a.camera + "'").c_str());
  auto scene = render::ParseScene(a.scene);
  if (!scene.ok()) return Fail("render", scene.status().message().c_str());
  o.scene = *scene;
  auto tonemap = render::ParseTonemap(a.tonemap);
  if (!tonemap.ok()) return Fail("render", tonemap.status().message().c_str());
  o.tonemap = *tonemap;
  const bool exr = EndsWith(a.out, ".exr");
  if (!exr && !EndsWith(a.out, ".png"))
    return Fail(
        "render",
        ("--out must end in .png (8-bit sRGB) or .exr (linear), got '" + a.out + "'").c_str());
  o.display = !exr;
  if (a.sweep < 0 || a.sweep > 64)
    return Fail(
        "render",
        ("--sweep must be in [1, 64] (0 = one image), got " + std::to_string(a.sweep)).c_str());
  std::string why;
  if (!o.Check(&why)) return Fail("render", why.c_str());
  if (a.backend != "auto" && a.backend != "egl" && a.backend != "cpu")
    return Fail("render",
                ("unknown --backend '" + a.backend + "'; choose auto, egl or cpu").c_str());
  if (Status st = CheckOutput(a.out, a.force); !st.ok())
    return Fail("render", st.message().c_str());
  if (EndsWith(a.pack, ".zip"))
    return Fail("render", "zipped packs are not read yet; unzip it and pass the folder");
  auto pack = ReadPack(a.pack);
  if (!pack.ok()) return Fail("render", pack.status().message().c_str());
  // A per-view pack (per-view:<model>): the maps of the fitted view nearest the camera.
  if (const int v = NearestPackView(*pack, o.camera_theta_deg, o.camera_phi_deg); v >= 0) {
    if (!a.quiet)
      std::fprintf(stderr, "matfit render: per-view pack: drawing the maps of view %g,%g\n",
                   pack->views[size_t(v)].theta_deg, pack->views[size_t(v)].phi_deg);
    pack->maps = std::move(pack->views[size_t(v)].maps);
  }

  std::unique_ptr<render::EglRenderer> egl;
  if (a.backend != "cpu") {
    auto r = render::EglRenderer::Create();
    if (r.ok()) {
      egl = std::move(*r);
    } else if (a.backend == "egl") {
      return Fail("render", r.status().message().c_str());
    } else if (!a.quiet) {
      std::fprintf(stderr, "matfit render: %s; rendering on the CPU\n",
                   r.status().message().c_str());
    }
  }
  auto draw = [&](const render::RenderOptions& ro) {
    return egl ? egl->Render(pack->maps, ro) : render::RenderCpu(pack->maps, ro);
  };
  Image out;
  if (a.sweep == 0) {
    auto img = draw(o);
    if (!img.ok()) return Fail("render", img.status().message().c_str());
    out = std::move(*img);
  } else {
    // Contact sheet: the light circles the sample at the given θ, φ = 360° k / N.
    const int cols = int(std::ceil(std::sqrt(double(a.sweep))));
    const int rows = (a.sweep + cols - 1) / cols, S = o.size;
    out = Image(cols * S, rows * S, 4);
    for (int k = 0; k < a.sweep; ++k) {
      render::RenderOptions ro = o;
      ro.phi_deg = o.phi_deg + 360.0 * k / a.sweep;
      auto img = draw(ro);
      if (!img.ok()) return Fail("render", img.status().message().c_str());
      const int x0 = (k % cols) * S, y0 = (k / cols) * S;
      for (int c = 0; c < 4; ++c)
        for (int y = 0; y < S; ++y)
          for (int x = 0; x < S; ++x)
            out.Plane(c)[int64_t(y0 + y) * out.width() + x0 + x] =
                img->Plane(c)[int64_t(y) * S + x];
    }
  }
  ImageWriteOptions wo;
  wo.format = exr ? PixelFormat::kFloat : PixelFormat::kUint8;
  wo.transfer = TransferFunction::kLinear;  // PNG values are already sRGB-encoded
  if (Status st = WriteImage(a.out, out, wo); !st.ok()) return Fail("render", st.message().c_str());
  if (!a.quiet)
    std::printf("rendered %s (%s, %s, %d × %d) with %s\n", a.out.c_str(),
                ShadingModelName(pack->maps.model), render::SceneName(o.scene), out.width(),
                out.height(), egl ? egl->Description().c_str() : "the CPU reference renderer");
  return 0;
}

}  // namespace

void RegisterRender(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* sub = app.add_subcommand("render", "Preview a material pack under a directional light");
  sub->add_option("PACK", args->pack, "material pack folder")->required();
  sub->add_option("--out", args->out, "output .png (8-bit sRGB) or .exr (linear)")->required();
  sub->add_option("--light", args->light, "light THETA,PHI in degrees")->capture_default_str();
  sub->add_option("--camera", args->camera,
                  "orthographic camera THETA,PHI in degrees (0,0 = straight down; θ ≤ 80)")
      ->capture_default_str();
  sub->add_option("--scene", args->scene, "plane, sphere or cloth")->capture_default_str();
  sub->add_option("--size", args->options.size, "output size in pixels")->capture_default_str();
  sub->add_option("--backend", args->backend, "auto (EGL, else CPU), egl or cpu")
      ->capture_default_str();
  sub->add_option("--sweep", args->sweep,
                  "contact sheet of N light azimuths at the --light elevation")
      ->capture_default_str();
  sub->add_option("--intensity", args->options.intensity, "light intensity")->capture_default_str();
  sub->add_option("--ambient", args->options.ambient, "ambient light (× albedo)")
      ->capture_default_str();
  sub->add_option("--exposure", args->options.exposure, "exposure multiplier (PNG)")
      ->capture_default_str();
  sub->add_option("--tonemap", args->tonemap, "clamp or reinhard (PNG)")->capture_default_str();
  sub->add_flag("--force", args->force, kForceHelp);
  sub->add_option("--threads", args->threads, kThreadsHelp + std::string(" (CPU backend)"))
      ->capture_default_str();
  sub->add_flag("--quiet", args->quiet, "no summary line");
  sub->callback([args, exit_code] { *exit_code = RunRender(*args); });
}

}  // namespace matfit::app
