// The whole `matfit fit` path as one controller: read → fit → score (reconstruction, held-out
// lights, truth when present) → report.json → material pack. The CLI and the server share it.
// Every stage is timed (report.json "timings") and announced to the progress callback.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "core/dataset/dataset.h"
#include "fit/assess.h"
#include "fit/fit_types.h"
#include "fit/holdout.h"
#include "fit/holdout_views.h"
#include "fit/metrics.h"
#include "fit/per_view_pca.h"
#include "fit/report.h"
#include "fit/select.h"

namespace matfit {
class Comm;
}

namespace matfit::fit {

struct FitJobOptions {
  std::string input;              // dataset folder or .lp file
  std::string model = "lambert";  // or "auto": fit/select.h picks model and map resolution
  std::string scene;              // auto: scene.json (empty: a dynamic, full-resolution scene)
  double budget = 0;              // auto: error budget overriding the scene's (0 = keep)
  ReadOptions read;               // layout, view, colour space
  FitOptions fit;                 // tile, method options
  int holdout = 0;                // k-fold held-out-light error; 0 = off, ≥ 2, or kLeaveOneOut
  int holdout_views = 0;          // whole views left out and predicted (multi-view); 0 = off
  // --view all: the memory budget (bytes; 0 = kDefaultMemoryBudget, fit/stream_fit.h). A stack
  // whose float size is above it is fitted out of core: decoded once into a band cache in
  // cache_dir (empty: the system temp folder) and fitted band by band (svbrdf only).
  int64_t memory_bytes = 0;
  std::string cache_dir;
  // --components K,…: the per-view PCA reference of a multi-view fit (fit/per_view_pca.h) at
  // these component counts, in report.json per_view_pca (in-memory fits; empty: none).
  std::vector<int> pca_components;
  std::string out;          // pack folder (or .zip with zip); report file with report_only
  std::string report_only;  // score this existing pack against the dataset (no fitting)
  bool zip = false, overwrite = false;
  bool compact_maps = false;  // PackWriteOptions::compact
  // Read the dataset and stop: the decode floor (same reader, parallel decode and threads as a
  // fit; no fit, no scores, nothing written). Not with out, report_only or holdout.
  bool decode_only = false;
  // What report.json and material.json name as the input (empty: `input`). The server passes
  // a name that does not reveal its own folders.
  std::string source_label;
  // The ranks of a distributed fit (mpirun/srun; docs/scale-out.md); null or one rank: this
  // process fits the whole stack. Each rank reads and fits one band of rows; every figure is
  // reduced over the ranks, and rank 0 assembles the maps, scores against truth and writes the
  // pack and report, which equal a single process's. Not with report_only.
  // With comm, the progress callback must not cancel (the ranks would fall out of step).
  const Comm* comm = nullptr;

  bool Check(std::string* why) const;
};

struct FitJobResult {
  FitResult fit;
  int images = 0;
  ReconstructionMetrics reconstruction;
  ReconstructionMetrics reconstruction_common;  // every unmasked texel, as the pack stores it
  std::optional<HeldOutMetrics> heldout;
  std::optional<HeldOutViewMetrics> heldout_views;  // --holdout-views
  // Multi-view stacks: reconstruction dev% per (θv, θl) group (fit/holdout_views.h).
  std::map<int, std::map<int, double>> deviation_by_view_theta;
  int streamed_bands = 0;  // > 0: fitted out of core in that many bands (fit/stream_fit.h)
  std::vector<PcaPoint> per_view_pca;  // --components
  // --components: the per-view PCA at the largest k, stored in the pack's pca/ (moved there).
  std::vector<ViewPcaModel> per_view_pca_models;
  std::optional<TruthMetrics> truth;
  FitAssessment assessment;  // diagnostics + per-texel error bound (not report_only)
  std::optional<BoundRatio> bound_ratio_heldout, bound_ratio_truth;  // the bound's tightness
  std::optional<Selection> selection;                                // with model "auto"
  // --color-space auto: what the tone-curve estimate did to the read (fit/diagnostics.h).
  std::optional<ToneResolution> tone;
  std::string read_encoding;  // how the stack was linearised (DescribeReadEncoding)
  std::string report_json;
  int width = 0, height = 0, channels = 0;  // of the stack as read
  // Wall seconds per stage and in total. report.json holds them as of composing it (its write
  // and total stop there); here write and total run to the end of the job.
  StageTimings timings;
};

// With report_only: reads the pack, scores it against the dataset (reconstruction, truth when
// present), fills report_json and writes it to `out` when `out` is set.
// stage, in order: "read", "select" (auto), "fit", "reconstruction", "confidence", "heldout",
// "heldout-views", "pca" and "pca-store" (--components), "gather" (distributed: rank 0 collects
// the bands' maps), "truth", "write" (report_only: "read", "reconstruction", "truth"; out of
// core: "read", "cache", "start", "fit", "truth", "write"). Each stage is announced with done = 0
// and ends with done = total; return false to cancel.
using StageProgress = std::function<bool(const std::string& stage, int64_t done, int64_t total)>;

StatusOr<FitJobResult> RunFitJob(const FitJobOptions& options, const StageProgress& progress = {});

}  // namespace matfit::fit
