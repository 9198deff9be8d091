// `matfit leaf DIR --out DIR`: one translucent leaf material per leaf of a scanned sheet.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "app/commands.h"
#include "app/mpi_join.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/warnings.h"
#include "leaf/leaf_job.h"
#include "render/cpu_renderer.h"

namespace matfit::app {
namespace {

struct LeafArgs {
  leaf::LeafJobOptions job;
  std::string precompute = "fast";
  std::string crop;
  int preview_size = 256;
  bool no_preview = false, quiet = false;
  int threads = 0;
};

int RunLeaf(LeafArgs& a) {
  if (a.precompute != "fast" && a.precompute != "reference")
    return Fail("leaf", ("--precompute '" + a.precompute + "': choose fast or reference").c_str());
  a.job.material.reference_precompute = a.precompute == "reference";
  if (int rc = ApplyCropArg("leaf", a.crop, &a.job.crop)) return rc;
  if (a.preview_size < 16 || a.preview_size > 4096)
    return Fail("leaf", "--preview-size must be in 16..4096");
  // Started by mpirun/srun: the leaves are split over the ranks; rank 0 prints and writes.
  const MpiJoin mpi = JoinMpi();
  if (!mpi.error.empty()) return Fail("leaf", mpi.error.c_str());
  a.job.comm = mpi.world;
  if (!mpi.root) a.quiet = true;
  std::string why;
  if (!a.job.Check(&why)) return mpi.root ? Fail("leaf", why.c_str()) : 1;
  SetNumThreads(a.threads);
  if (!a.no_preview) {
    const int size = a.preview_size;
    a.job.preview = [size](const MaterialMaps& m, bool behind) {
      return render::RenderLeafPreview(m, behind, size);
    };
  }
  std::unique_ptr<ProgressReporter> bar;
  std::string current;
  auto progress = [&](const std::string& stage, int64_t done, int64_t total) {
    if (a.quiet) return true;
    if (stage != current) bar = std::make_unique<ProgressReporter>(stage), current = stage;
    bar->Update(done, total);
    return true;
  };
  auto r = leaf::RunLeafJob(a.job, progress);
  bar.reset();
  if (!r.ok()) return mpi.root ? Fail("leaf", r.status().message().c_str()) : 1;
  if (!mpi.root) return 0;
  if (mpi.ranks() > 1)
    std::printf("ranks       %d MPI ranks, leaf k fitted by rank k mod %d, %d thread%s per rank\n",
                mpi.ranks(), mpi.ranks(), NumThreads(), NumThreads() == 1 ? "" : "s");
  std::printf("found       %d leaves, %d twigs, %d markers (%d specks dropped)\n", r->leaves,
              r->twigs, r->markers, r->specks);
  std::printf("scale       %.4g mm/pixel (%s)\n", r->mm_per_pixel, r->scale_source.c_str());
  double worst = 0, mean = 0;
  for (const auto& s : r->summary)
    worst = std::max(worst, s.mean_hl2_error), mean += s.mean_hl2_error;
  if (!r->summary.empty())
    std::printf("hl2 error   mean %.2f %%, worst leaf %.2f %% (vs multipole at π/2, π/4, π/8)\n",
                100 * mean / r->summary.size(), 100 * worst);
  std::printf("time        %.2f s (sheet %.2f s, leaves %.2f s)\n", r->seconds_total,
              r->seconds_sheet, r->seconds_leaves);
  // The leaves a user should look at before using them: one line (leaves.json has each one's
  // leaf-flagged warning and flagged_fraction).
  std::string flagged;
  int n_flagged = 0;
  for (const auto& s : r->summary)
    if (s.flagged_fraction > leaf::kLeafFlaggedWarnFraction)
      flagged += (n_flagged++ ? ", " : "") + s.name + " " +
                 std::to_string(int(std::lround(100 * s.flagged_fraction))) + " %";
  if (n_flagged)
    std::printf(
        "warning     %s: %d of %zu leaves have more than %.0f %% of their texels flagged "
        "(their maps there are the best estimate, not a fit; see each status map): %s\n",
        WarningName(WarningCode::kLeafFlagged), n_flagged, r->summary.size(),
        100 * leaf::kLeafFlaggedWarnFraction, flagged.c_str());
  const std::string prefix = std::string(WarningName(WarningCode::kLeafFlagged)) + ":";
  for (const auto& w : r->warnings)
    if (w.rfind(prefix, 0) != 0) std::printf("warning     %s\n", w.c_str());
  std::printf("out         %s (%zu leaf packs, leaves.json)\n", a.job.out.c_str(),
              r->summary.size());
  return 0;
}

}  // namespace

void RegisterLeaf(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<LeafArgs>();
  auto& j = args->job;
  CLI::App* sub = app.add_subcommand(
      "leaf", "Segment a scanned leaf sheet and write one translucent leaf material per leaf");
  sub->add_option("DIR", j.input, "leaf-scan folder")->required();
  sub->add_option("--out", j.out, "output folder (leaves.json + one pack per leaf)")->required();
  sub->add_option("--manifest", j.manifest, "leaf-scan manifest (default: DIR/leaf.json)");
  sub->add_option("--nl", j.material.translucency.directions,
                  "light directions N_L of the HL2 projection")
      ->capture_default_str();
  sub->add_option("--max-thickness-mm", j.max_thickness_mm,
                  "measured maximum leaf thickness (scales the thickness estimate)");
  sub->add_option("--mm-per-pixel", j.mm_per_pixel, "physical scale of the scan");
  sub->add_option("--marker-size-mm", j.marker_size_mm, "side of the square markers (for scale)");
  sub->add_option("--precompute", args->precompute, "fast or reference (the direct method)")
      ->capture_default_str();
  sub->add_option("--leaf", j.only_leaf, "process only this leaf id");
  sub->add_option("--crop", args->crop, kCropHelp);
  sub->add_option("--preview-size", args->preview_size, "preview render size in pixels")
      ->capture_default_str();
  sub->add_flag("--no-preview", args->no_preview, "skip the front/back preview renders");
  sub->add_option("--threads", args->threads, kThreadsHelp)->capture_default_str();
  sub->add_flag("--force", j.overwrite, kForceHelp);
  sub->add_flag("--quiet", args->quiet, "no progress bars");
  sub->callback([args, exit_code] { *exit_code = RunLeaf(*args); });
}

}  // namespace matfit::app
