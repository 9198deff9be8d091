// matfit synth: write a synthetic dataset with ground truth.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "core/dataset/dataset.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/synth/materials.h"
#include "core/synth/synth.h"
#include "leaf/synthetic_scan.h"

namespace matfit::app {
namespace {

struct SynthArgs {
  synth::SynthOptions options;
  std::string layout = "bonn", out, size = "64";
  bool bits_given = false;
  bool force = false, list = false, leaf_scan = false, minimal = false, quiet = false;
  int threads = 0;
};

// --size N (square) or WxH, e.g. 512x344.
bool ParseSize(const std::string& text, int* width, int* height) {
  int w = 0, h = 0, used = 0;
  if (std::sscanf(text.c_str(), "%d%n", &w, &used) == 1 && used == int(text.size())) {
    *width = w, *height = 0;
    return true;
  }
  if (std::sscanf(text.c_str(), "%dx%d%n", &w, &h, &used) == 2 && used == int(text.size())) {
    *width = w, *height = h;
    return true;
  }
  return false;
}

int RunSynth(SynthArgs& a) {
  if (a.list) {
    std::printf("materials:\n");
    for (const auto& m : synth::Materials())
      std::printf("  %-11s %s%s\n", m.name.c_str(), m.description.c_str(),
                  m.self_shadowing ? " (cast shadows always on)" : "");
    std::printf("light sets:\n  bonn81, ring12, ring:N[:THETA], dome:N, random:N\n");
    return 0;
  }
  if (a.out.empty()) return Fail("synth", "--out DIR is required (except with --list)");
  if (!ParseSize(a.size, &a.options.size, &a.options.height))
    return Fail("synth",
                ("--size must be N or WIDTHxHEIGHT (e.g. 512x344), got '" + a.size + "'").c_str());
  // The format's own depth unless --bits says otherwise (then Check names the mismatch).
  if (!a.bits_given && a.options.format == "jpg") a.options.bits = 8;
  if (!a.bits_given && a.options.format == "exr") a.options.bits = 32;
  if (a.leaf_scan) {
    if (a.options.height > 0) return Fail("synth", "--leaf-scan takes --size N (the leaf width)");
    // A leaf-rig scan (ring-lit + back-lit sheet with markers) of the synthetic leaf, --size
    // pixels wide, on a sheet 1.75 × 1.3 times that.
    leaf::SyntheticScanOptions so;
    so.leaf_size = a.options.size;
    so.width = std::max(64, int(a.options.size * 1.75));
    so.height = std::max({64, int(a.options.size * 1.3), a.options.size + 24});
    so.seed = a.options.seed, so.minimal = a.minimal;
    std::string why;
    if (!so.Check(&why)) return Fail("synth", ("--leaf-scan: " + why).c_str());
    std::unique_ptr<ProgressReporter> bar;
    if (!a.quiet) bar = std::make_unique<ProgressReporter>("render");
    const auto s = leaf::MakeSyntheticScan(so, bar ? bar->Callback() : ProgressFn());
    if (!a.quiet) bar = std::make_unique<ProgressReporter>("write");
    Status st = leaf::WriteLeafScan(s, a.out, a.force, bar ? bar->Callback() : ProgressFn());
    bar.reset();
    if (!st.ok()) return Fail("synth", st.message().c_str());
    if (!a.quiet)
      std::printf(
          "wrote %s: synthetic leaf scan %dx%d (%s + %zu back-lit images), truth in %s/truth\n",
          a.out.c_str(), so.width, so.height, a.minimal ? "front-lit photo" : "12 ring lights",
          s.scan.back.size(), a.out.c_str());
    return 0;
  }
  if (!ParseLayout(a.layout, &a.options.layout) || a.options.layout == Layout::kAuto)
    return Fail("synth", ("--layout '" + a.layout +
                          "' is not one of bonn, utia, lp, diligent, "
                          "lights-txt")
                             .c_str());
  SetNumThreads(a.threads);
  std::string why;
  if (!a.options.Check(&why)) return Fail("synth", why.c_str());
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<ProgressReporter> bar;
  if (!a.quiet) bar = std::make_unique<ProgressReporter>("render");
  auto result = synth::Synthesize(a.options, bar ? bar->Callback() : ProgressFn());
  if (!result.ok()) return Fail("synth", result.status().message().c_str());
  if (!a.quiet) bar = std::make_unique<ProgressReporter>("write");
  Status st = synth::WriteSynthDataset(*result, a.options, a.out, a.force,
                                       bar ? bar->Callback() : ProgressFn());
  bar.reset();
  if (!st.ok()) return Fail("synth", st.message().c_str());
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (a.quiet) return 0;
  std::printf(
      "wrote %s: %s under %s, %d images of %dx%d (%s layout, %d-bit %s), truth in %s/truth "
      "(%.2f s)\n",
      a.out.c_str(), a.options.material.c_str(), a.options.lights.c_str(),
      result->stack.num_images(), a.options.size, a.options.rows(), a.layout.c_str(),
      a.options.bits,
      a.options.format == "jpg" ? "JPEG"
      : a.options.bits == 32    ? "EXR"
                                : "PNG",
      a.out.c_str(), secs);
  if (result->perturb.clipped_samples > 0)
    std::printf("note: %lld samples were clipped at %.3g\n",
                (long long)result->perturb.clipped_samples, a.options.perturb.clip);
  return 0;
}

}  // namespace

void RegisterSynth(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<SynthArgs>();
  auto& o = args->options;
  CLI::App* sub = app.add_subcommand("synth",
                                     "Render a procedural material with known maps into "
                                     "a dataset folder (+ truth/)");
  sub->add_option("--material", o.material,
                  "plaster, plastic, plastic-ct, wool, corduroy, granite, leaf")
      ->capture_default_str();
  sub->add_option("--lights", o.lights, "bonn81, ring12, ring:N[:THETA], dome:N, random:N")
      ->capture_default_str();
  sub->add_option("--views", o.views,
                  "a multi-view BTF (layouts bonn, utia): the camera directions as a light set "
                  "(bonn81, dome:N, …); every view × light rendered rectified, with parallax");
  sub->add_option("--size", args->size, "texels per side N, or WIDTHxHEIGHT (e.g. 512x344)")
      ->capture_default_str();
  sub->add_option("--noise", o.perturb.gaussian_sigma, "Gaussian noise σ, fraction of full scale")
      ->capture_default_str();
  sub->add_option("--shot-noise", o.perturb.shot_photons, "photons at full scale (0 = off)")
      ->capture_default_str();
  sub->add_flag("--shadows", o.shadows, "cast shadows from the height field");
  sub->add_option("--near-lights", o.near_lights,
                  "near (point) lights at this distance in texels from the image centre, with "
                  "per-texel directions and 1/r² fall-off (writes light_positions.txt); 0 = "
                  "distant");
  sub->add_option("--clip", o.perturb.clip, "saturate at this level in (0, 1] (0 = off)")
      ->capture_default_str();
  sub->add_option("--misregister", o.perturb.misregister_px, "max random shift per image, px")
      ->capture_default_str();
  sub->add_option("--seed", o.seed, "random seed (output is a function of it)")
      ->capture_default_str();
  sub->add_option("--layout", args->layout, "bonn, utia, lp, diligent, lights-txt")
      ->capture_default_str();
  sub->add_option("--bits", o.bits, "8 (sRGB PNG), 16 (linear PNG), 32 (float EXR)")
      ->capture_default_str();
  sub->add_option("--format", o.format,
                  "image files: auto (PNG for 8/16-bit, EXR for 32), png, jpg (8-bit sRGB), exr")
      ->capture_default_str();
  sub->add_option("--out", args->out,
                  std::string("output folder (created atomically) ") + RequiredUnless("--list"));
  sub->add_flag("--force", args->force, kForceHelp);
  sub->add_option("--threads", args->threads, kThreadsHelp)->capture_default_str();
  sub->add_flag("--quiet", args->quiet, "no progress or summary output");
  sub->add_flag("--list", args->list, "list materials and light sets");
  sub->add_flag("--leaf-scan", args->leaf_scan,
                "write a leaf-rig scan of the synthetic leaf (for `matfit leaf`) instead");
  sub->add_flag("--minimal", args->minimal, "with --leaf-scan: one front-lit photo, no ring");
  sub->callback([args, exit_code, sub] {
    args->bits_given = sub->get_option("--bits")->count() > 0;
    *exit_code = RunSynth(*args);
  });
}

}  // namespace matfit::app
