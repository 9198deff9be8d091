// matfit fit: dataset → material pack, with a summary table.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>

#include "app/commands.h"
#include "app/mpi_join.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "fit/diagnostics.h"
#include "fit/fit_job.h"
#include "fit/method.h"

namespace matfit::app {
namespace {

struct FitArgs {
  fit::FitJobOptions job;
  std::string layout = "auto", view, color_space = "auto", crop, memory;
  int threads = 0;
  bool quiet = false;
};

void PrintModels() {
  std::printf("%-10s %6s %6s  %s\n", "model", "params", "bytes", "description (per texel)");
  std::vector<std::string> names = fit::MethodNames();
  for (const auto& name : fit::MultiViewMethodNames()) names.push_back(name);
  for (const auto& name : names) {
    const auto m = fit::MakeMethod(name);
    std::printf("%-10s %6d %6d  %s\n", name.c_str(), m->parameters_per_texel(),
                m->bytes_per_texel(), m->description().c_str());
  }
  std::printf(
      "per-view:MODEL  any model above but svbrdf fitted to each view of a BTF on its own (--view "
      "all; params and bytes per view)\n");
}

// "512M", "2G", "1048576" → bytes (K, M, G: powers of 1024); false when malformed or ≤ 0.
bool ParseByteSize(const std::string& text, int64_t* out) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !(v > 0)) return false;
  double scale = 1;
  const std::string suffix(end);
  if (suffix == "K" || suffix == "k")
    scale = 1024.0;
  else if (suffix == "M" || suffix == "m")
    scale = 1024.0 * 1024;
  else if (suffix == "G" || suffix == "g")
    scale = 1024.0 * 1024 * 1024;
  else if (!suffix.empty())
    return false;
  if (!(v * scale < 9e18)) return false;
  *out = int64_t(v * scale);
  return *out > 0;
}

std::string ByTheta(const std::map<int, double>& m) {
  std::string s;
  char buf[48];
  for (const auto& [t, d] : m) {
    std::snprintf(buf, sizeof buf, " %d°:%.4g", t, d);
    s += buf;
  }
  return s;
}

// "read 2.10 s, fit 0.17 s, …; total 3.50 s"
std::string Timings(const fit::StageTimings& t) {
  std::string s;
  char buf[96];
  for (const auto& [stage, seconds] : t.stages) {
    std::snprintf(buf, sizeof buf, "%s%s %.3g s", s.empty() ? "" : ", ", stage.c_str(), seconds);
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "; total %.3g s", t.total);
  return s + buf;
}

int RunFit(FitArgs& a) {
  if (a.job.model == "list") {
    PrintModels();
    return 0;
  }
  // Started by mpirun/srun: one band of rows per rank; rank 0 reports and writes the pack.
  const MpiJoin mpi = JoinMpi();
  if (!mpi.error.empty()) return Fail("fit", mpi.error.c_str());
  const bool root = mpi.root;
  a.job.comm = mpi.world;
  if (!root) a.quiet = true;
  if (int rc = ApplyReadArgs("fit", a.layout, a.view, a.color_space, a.crop, &a.job.read))
    return rc;
  if (!a.memory.empty() && !ParseByteSize(a.memory, &a.job.memory_bytes))
    return Fail("fit", ("--memory '" + a.memory +
                        "' must be a size: a number of bytes with an optional K, M or G suffix "
                        "(e.g. 512M, 2G)")
                           .c_str());
  std::string why;
  if (!a.job.Check(&why)) return root ? Fail("fit", why.c_str()) : 1;
  SetNumThreads(a.threads);

  std::unique_ptr<ProgressReporter> bar;
  std::string current;
  auto progress = [&](const std::string& stage, int64_t done, int64_t total) {
    if (a.quiet) return true;
    if (stage != current) {
      bar = std::make_unique<ProgressReporter>(stage);
      current = stage;
    }
    bar->Update(done, total);
    return true;
  };
  auto r = fit::RunFitJob(a.job, progress);
  bar.reset();
  // Rank 0 prints every error the ranks agreed on (a file that failed on another rank's rows is
  // named in it) and the summary; the other ranks print nothing.
  if (!r.ok()) return root ? Fail("fit", r.status().message().c_str()) : 1;
  if (!root) return 0;
  if (mpi.ranks() > 1)
    std::printf("ranks       %d MPI ranks, one band of rows each, %d thread%s per rank\n",
                mpi.ranks(), NumThreads(), NumThreads() == 1 ? "" : "s");
  if (a.job.decode_only) {
    std::printf("decoded     %d images of %dx%d, %d channel%s, %d thread%s\n", r->images, r->width,
                r->height, r->channels, r->channels == 1 ? "" : "s", NumThreads(),
                NumThreads() == 1 ? "" : "s");
    std::printf("timings     %s\n", Timings(r->timings).c_str());
    return 0;
  }

  const auto& f = r->fit;
  std::printf("method      %s (%s)\n", f.method.c_str(), ShadingModelName(f.maps.model));
  std::printf("texels      %d x %d, %lld flagged; %d images\n", f.maps.width, f.maps.height,
              (long long)f.flagged_texels, r->images);
  if (f.refit_texels > 0)
    std::printf(
        "dropped     %lld clipped/non-finite samples; %lld texels fitted from their other "
        "lights (maps/dropped.png)\n",
        (long long)f.dropped_samples, (long long)f.refit_texels);
  if (a.job.report_only.empty()) {
    std::printf("fit time    %.3f s\n", f.fit_seconds);
    std::printf("read as     %s\n", r->read_encoding.c_str());
    std::printf("tone curve  %s\n", fit::DescribeToneCurve(r->assessment.diagnostics).c_str());
  }
  for (const auto& [k, v] : f.parameters) std::printf("parameter   %s = %.6g\n", k.c_str(), v);
  std::printf("deviation   %.5f %%  by θl:%s\n", r->reconstruction.deviation_percent,
              ByTheta(r->reconstruction.deviation_percent_by_theta).c_str());
  std::printf("rmse        %.5f  (PSNR %.1f dB)\n", r->reconstruction.rmse,
              r->reconstruction.psnr_db);
  if (r->heldout)
    std::printf(
        "held-out    rmse %.5f, deviation %.5f %%, sRGB 8-bit PSNR %.2f dB over %d folds (%d "
        "failed)\n",
        r->heldout->rmse, r->heldout->deviation_percent, r->heldout->psnr_srgb8_db,
        r->heldout->folds, r->heldout->failed_folds);
  if (r->heldout_views) {
    std::string views;
    for (const fit::HeldOutView& v : r->heldout_views->views)
      views += (views.empty() ? "" : ", ") + std::to_string(int(std::lround(v.theta_deg))) + "/" +
               std::to_string(int(std::lround(v.phi_deg)));
    std::printf(
        "held-out    views: rmse %.5f, deviation %.5f %% over %zu views (θv/φv %s), fitted on "
        "%d\n",
        r->heldout_views->all.rmse, r->heldout_views->all.deviation_percent,
        r->heldout_views->views.size(), views.c_str(), r->heldout_views->train_views);
  }
  for (const fit::PcaPoint& pt : r->per_view_pca)
    std::printf(
        "per-view PCA k=%d: %.0f bytes/texel, rmse %.5f (the fit: %d bytes/texel, rmse "
        "%.5f)\n",
        pt.k, pt.bytes_per_texel, pt.rmse,
        fit::MakeMethod(r->fit.method)->bytes_per_texel() *
            std::max<int>(1, int(r->fit.views.size())),
        r->reconstruction.rmse);
  for (const auto& [tv, by_light] : r->deviation_by_view_theta)
    std::printf("deviation   θv %2d°: by θl:%s\n", tv, ByTheta(by_light).c_str());
  for (const auto& [what, ratio] : {std::pair{"held-out lights", r->bound_ratio_heldout},
                                    std::pair{"truth", r->bound_ratio_truth}})
    if (ratio && ratio->texels > 0)
      std::printf(
          "bound       %.2f× the %s error (median over %lld texels; p90 %.2f×; exceeded on "
          "%.2f %%)\n",
          ratio->median, what, (long long)ratio->texels, ratio->p90,
          100 * ratio->exceeded_fraction);
  if (const fit::Confidence& c = r->assessment.confidence; c.saturated > 0) {
    const Vec3& l = c.recorded_limit;
    char limit[96];
    if (l.x == l.y && l.y == l.z)
      std::snprintf(limit, sizeof limit, "%.4g", l.x);
    else
      std::snprintf(limit, sizeof limit, "%.4g, %.4g, %.4g (r, g, b)", l.x, l.y, l.z);
    std::printf(
        "bound       within the recorded range (up to %s per unit light, the clip level): "
        "%lld texels saturated, their appearance above it is the model's extrapolation\n",
        limit, (long long)c.saturated);
  }
  if (r->truth && r->truth->has_normal)
    std::printf("vs truth    normal MAE %.3f°, p95 %.3f°\n", r->truth->normal_mae_deg,
                r->truth->normal_p95_deg);
  if (r->truth && r->truth->has_albedo)
    std::printf("vs truth    albedo RMSE %.5f\n", r->truth->albedo_rmse);
  for (const auto& w : f.warnings) std::printf("warning     %s\n", w.c_str());
  std::printf("timings     %s\n", Timings(r->timings).c_str());
  if (a.job.report_only.empty())
    std::printf("pack        %s%s\n", a.job.out.c_str(), a.job.zip ? " (zip)" : "");
  else if (!a.job.out.empty())
    std::printf("report      %s\n", a.job.out.c_str());
  return 0;
}

}  // namespace

void RegisterFit(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<FitArgs>();
  auto& j = args->job;
  CLI::App* sub =
      app.add_subcommand("fit", "Fit a material model to a dataset and write a material pack");
  sub->add_option("DIR", j.input,
                  std::string("dataset folder (or .lp file) ") + RequiredUnless("--model list"));
  sub->add_option("--model", j.model, "model of the ladder, 'auto' (selection), or 'list'")
      ->capture_default_str();
  sub->add_option("--scene", j.scene,
                  "--model auto: scene.json (footprint, lighting, budgets; docs/selection.md)");
  sub->add_option("--budget", j.budget, "--model auto: held-out RMSE budget (linear)");
  sub->add_option("--out", j.out,
                  std::string("pack folder (or .zip file with --zip), written atomically ") +
                      RequiredUnless("--decode-only, --report-only or --model list"));
  sub->add_flag("--zip", j.zip, "write the pack as one zip file");
  sub->add_flag("--compact-maps", j.compact_maps,
                "smaller map files, slower to write (PNG zlib level 6 and PIZ-compressed EXR "
                "instead of level 1 and uncompressed EXR; lossless either way)");
  sub->add_flag("--force", j.overwrite, kForceHelp);
  sub->add_option("--holdout", j.holdout,
                  "k-fold held-out-light error: K folds, loo (leave-one-out) or 0 (off)")
      ->transform(CLI::Transformer(std::map<std::string, int>{{"loo", fit::kLeaveOneOut}}))
      ->capture_default_str();
  sub->add_option("--components", j.pca_components,
                  "multi-view stacks (--view all): also the per-view PCA reference with these "
                  "component counts (e.g. 1,2,4,8): bytes per texel and RMSE in report.json")
      ->delimiter(',');
  sub->add_option("--holdout-views", j.holdout_views,
                  "multi-view stacks (--view all): leave K whole views out of a second fit and "
                  "predict them (never the most frontal view); 0 = off")
      ->capture_default_str();
  sub->add_option("--view", args->view,
                  "BTF view THETA,PHI in degrees (default: most frontal), or all (every view × "
                  "light: --model svbrdf)");
  sub->add_option("--crop", args->crop, kCropHelp);
  sub->add_option("--memory", args->memory,
                  "--view all: memory budget (e.g. 512M, 2G; default 2G); a stack larger as float "
                  "is decoded once into a band cache on disk and fitted band by band (svbrdf)");
  sub->add_option("--cache-dir", j.cache_dir,
                  "where the out-of-core band cache goes (default: the system temp folder); "
                  "needs the stack's size at its file depth");
  sub->add_option("--layout", args->layout, "auto, bonn, utia, lp, diligent, lights-txt")
      ->capture_default_str();
  sub->add_option("--color-space", args->color_space, "auto, srgb or linear")
      ->capture_default_str();
  sub->add_flag("--distant-lights", j.read.distant_lights,
                "ignore light_positions.txt: treat every light as distant, along its direction "
                "from the image centre");
  sub->add_option("--near-tolerance", j.fit.near_tolerance_deg,
                  "near lights: largest angle (degrees) between a texel's light direction and "
                  "the one its tile is fitted with")
      ->capture_default_str();
  sub->add_option("--threads", args->threads, kThreadsHelp)->capture_default_str();
  sub->add_option("--tile", j.fit.tile, "work unit ≈ tile² texels")->capture_default_str();
  sub->add_flag("--flat-specular-normal", j.fit.heinrich_flat_specular_normal,
                "heinrich: n_s = (0,0,1) in the specular term");
  sub->add_option("--robust-scale", j.fit.robust_scale,
                  "nonlinear models: Cauchy loss scale on residuals (0 = least squares)")
      ->capture_default_str();
  sub->add_flag("--per-texel-lobe", j.fit.per_texel_lobe,
                "nonlinear models: fit the lobe shape per texel instead of once per material");
  sub->add_option("--lobe-shape-texels", j.fit.lobe_shape_texels,
                  "nonlinear models: the material's lobe shape is the median of per-texel fits "
                  "on a grid of about this many texels (0 = every texel)")
      ->capture_default_str();
  sub->add_option(
      "--report-only", j.report_only,
      "score this existing pack against DIR instead of fitting (--out: report.json path)");
  sub->add_flag("--decode-only", j.decode_only,
                "only read (decode) the dataset, as a fit would, and print the time: the floor "
                "of the whole process");
  sub->add_flag("--quiet", args->quiet, "no progress output");
  sub->callback([args, exit_code] {
    if (args->job.model != "list" && args->job.input.empty()) {
      *exit_code = Fail("fit", "a dataset DIR is required (or --model list)");
      return;
    }
    *exit_code = RunFit(*args);
  });
}

}  // namespace matfit::app
