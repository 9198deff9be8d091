#include "fit/fit_job.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include "core/atomic_file.h"
#include "core/comm.h"
#include "core/dataset/info.h"
#include "core/output_marker.h"
#include "core/pack/pack_reader.h"
#include "core/stack_band.h"
#include "core/stack_ops.h"
#include "core/synth/truth_io.h"
#include "core/warnings.h"
#include "fit/assess.h"
#include "fit/bands.h"
#include "fit/fit_common.h"
#include "fit/fit_job_finish.h"
#include "fit/fit_job_stages.h"
#include "fit/fit_job_streamed.h"
#include "fit/method.h"
#include "fit/per_view_fit.h"
#include "fit/score.h"
#include "fit/stream_fit.h"

namespace matfit::fit {

using job::Cancelled;
using job::CropRegion;
using job::FinishJob;
using job::RunStreamedJob;
using job::Stages;
using job::TruthOfRegion;

bool FitJobOptions::Check(std::string* why) const {
  auto fail = [why](std::string message) {
    *why = std::move(message);
    return false;
  };
  if (input.empty()) return fail("the dataset path is empty");
  if (decode_only) {
    if (!out.empty() || !report_only.empty() || holdout != 0 || holdout_views != 0)
      return fail(
          "--decode-only only reads the dataset: drop --out, --report-only, --holdout and "
          "--holdout-views");
    return read.Check(why);
  }
  if (out.empty() && report_only.empty()) return fail("--out PACK is required");
  if (model == "auto") {
    if (!report_only.empty()) return fail("--report-only scores an existing pack: no --model auto");
    if (budget < 0 || !std::isfinite(budget)) return fail("--budget must be > 0 (0 = the scene's)");
  } else if (!scene.empty() || budget != 0) {
    return fail("--scene and --budget go with --model auto");
  } else if (!MakeMethod(model)) {
    std::string list;
    for (const auto& n : MethodNames()) list += (list.empty() ? "" : ", ") + n;
    for (const auto& n : MultiViewMethodNames()) list += ", " + n + " (every view of a BTF)";
    list += ", per-view:MODEL (MODEL one of the first " + std::to_string(MethodNames().size()) +
            ", fitted to each view of a BTF)";
    return fail("--model '" + model + "' is not a method; choose one of: " + list + " (or auto)");
  }
  if (comm && comm->size() > 1) {
    if (!report_only.empty())
      return fail(
          "--report-only is not run across MPI ranks; run it in one process (without "
          "mpirun)");
  }
  if (memory_bytes < 0)
    return fail("--memory must be a size in bytes (e.g. 512M, 2G), got " +
                std::to_string(memory_bytes));
  if (holdout_views < 0)
    return fail("--holdout-views must be 0 (off) or a number of views, got " +
                std::to_string(holdout_views));
  for (int k : pca_components)
    if (k < 1 || k > 4096)
      return fail("--components takes component counts in [1, 4096], got " + std::to_string(k));
  if ((memory_bytes > 0 || !cache_dir.empty()) && !read.all_views)
    return fail(
        "--memory and --cache-dir apply to every view of a BTF (--view all); a single-view "
        "fit runs in memory: drop them or add --view all");
  if (!pca_components.empty() && !read.all_views)
    return fail("--components is the per-view PCA of every view: read them with --view all");
  if (holdout_views > 0 && !read.all_views)
    return fail("--holdout-views leaves whole views out: read every view with --view all");
  if (holdout_views > 0 && (!report_only.empty() || (comm && comm->size() > 1)))
    return fail("--holdout-views runs in a fit of one process (no --report-only or mpirun)");
  if (!pca_components.empty() && (!report_only.empty() || (comm && comm->size() > 1)))
    return fail("--components runs in a fit of one process (no --report-only or mpirun)");
  if (holdout == 1 || (holdout < 0 && holdout != kLeaveOneOut))
    return fail("--holdout must be 0 (off), ≥ 2 folds or loo (leave-one-out), got " +
                std::to_string(holdout));
  return read.Check(why) && fit.Check(why);
}

StatusOr<FitJobResult> RunFitJob(const FitJobOptions& o, const StageProgress& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  // Refuse an occupied --out before the long work, not after it.
  if (!o.out.empty()) MATFIT_RETURN_IF_ERROR(CheckOutput(o.out, o.overwrite));
  SceneSpec scene;  // --model auto: what the selection aims at
  if (o.model == "auto") {
    if (!o.scene.empty()) {
      std::ifstream in(o.scene, std::ios::binary);
      if (!in) return NotFound("cannot read the scene file '" + o.scene + "'");
      std::stringstream text;
      text << in.rdbuf();
      auto parsed = ParseScene(text.str(), o.scene);
      if (!parsed.ok()) return parsed.status();
      scene = *parsed;
    }
    if (o.budget > 0) scene.error_budget = o.budget;
  }
  Stages stages(progress);
  if (!stages.Begin("read")) return Cancelled();
  // Every view of a BTF over the memory budget: out of core (fit/stream_fit.h), from its headers.
  if (o.read.all_views && !o.decode_only && o.report_only.empty() &&
      !(o.comm && o.comm->size() > 1)) {
    auto streamed = StreamedFit::Open(o.input, o.read);
    if (!streamed.ok()) return streamed.status();
    const int64_t budget = o.memory_bytes > 0 ? o.memory_bytes : kDefaultMemoryBudget;
    if (streamed->FloatBytes() > budget) return RunStreamedJob(o, budget, &*streamed, &stages);
  }
  ReadOptions ro = o.read;
  ro.progress = stages.Callback();
  ro.diagnosis_probe = !o.decode_only;
  // Distributed: this rank reads only its band of rows of every image (fit/bands.h).
  const Comm* comm = o.comm && o.comm->size() > 1 ? o.comm : nullptr;
  if (comm) {
    ReadOptions headers = o.read;
    headers.headers_only = true;
    auto shape = ReadDataset(o.input, headers);
    if (!shape.ok()) return shape.status();  // the same files, the same error on every rank
    // Model selection downsamples the stack: bands of whole blocks of its coarsest mip.
    const int multiple =
        o.model == "auto" ? SelectionRowMultiple(scene, shape->width(), shape->height(), {}) : 1;
    auto band = SplitRows(shape->width(), shape->height(), comm->rank(), comm->size(), multiple);
    if (!band.ok()) return band.status();
    ro.row0 = band->row0, ro.rows = band->rows;
  }
  auto stack = ReadDataset(o.input, ro);
  if (comm) {
    // A file that fails on one rank's rows fails the job on every rank, with its message.
    std::string failed;
    if (!AllOk(*comm, stack.ok(), stack.ok() ? "" : stack.status().message(), &failed))
      return stack.ok() ? DataError(failed) : stack.status();
    MATFIT_RETURN_IF_ERROR(JoinBands(&*stack, comm));  // the same outcome on every rank
  }
  if (!stack.ok()) return stack.status();
  FitJobResult r;
  // --color-space auto: the tone curve the stack shows overrides a rule's guess (docs/data-model.md
  // "Colour"). The same diagnosis serves the assessment (reset when --model auto downsamples the
  // stack); --decode-only times the decode alone and skips it.
  std::optional<StackDiagnostics> diagnosis;
  if (!o.decode_only) diagnosis = DiagnoseStack(*stack);
  std::vector<std::string> tone_warnings;
  if (diagnosis && o.read.color_space == ColorSpaceChoice::kAuto) {
    r.tone = ResolveToneCurve(&*stack, &*diagnosis);
    if (r.tone->corrected) tone_warnings.push_back(diagnosis->warnings.front());
    // The assessment appends the diagnosis's warnings; this one is the dataset's (above).
    if (r.tone->corrected) diagnosis->warnings.erase(diagnosis->warnings.begin());
  }
  stack->probe.reset();  // the diagnosis is made: its texels' codes are not needed again
  std::optional<PackContents> pack;
  if (!o.report_only.empty()) {
    auto p = ReadPack(o.report_only);
    if (!p.ok()) return p.status();
    pack = std::move(*p);
  }
  stages.End();
  r.images = stack->num_images();
  r.read_encoding = DescribeReadEncoding(*stack);
  r.width = stack->width(), r.height = stack->full_height(), r.channels = stack->channels();
  if (o.decode_only) {
    r.timings = stages.Snapshot();
    return r;
  }
  // What is wrong with the data itself (coverage, clipping, light file, alpha) heads the fit's
  // warnings, as `matfit info` reports it.
  std::vector<std::string> dataset_warnings = ComputeDatasetInfo(*stack).warnings;
  dataset_warnings.insert(dataset_warnings.begin(), tone_warnings.begin(), tone_warnings.end());
  auto with_dataset_warnings = [&](std::vector<std::string>* w) {
    w->insert(w->begin(), dataset_warnings.begin(), dataset_warnings.end());
  };
  if (pack) {
    if (pack->maps.width != stack->width() || pack->maps.height != stack->height())
      return InvalidArgument("pack '" + o.report_only + "' is " + std::to_string(pack->maps.width) +
                             "x" + std::to_string(pack->maps.height) + " but the dataset is " +
                             std::to_string(stack->width()) + "x" +
                             std::to_string(stack->height()));
    r.fit.maps = std::move(pack->maps);
    r.fit.status = std::move(pack->status);
    r.fit.method = pack->method;
    // A per-view pack: each image scored with its nearest view's maps (fit/per_view_fit.h).
    for (PackViewContents& v : pack->views)
      r.fit.views.push_back({v.theta_deg, v.phi_deg, DirectionFromAnglesDeg(v.theta_deg, v.phi_deg),
                             std::move(v.maps), std::move(v.status)});
    with_dataset_warnings(&r.fit.warnings);
    for (uint8_t st : r.fit.status) r.fit.flagged_texels += st != 0 && st != 1;
    if (!stages.Begin("reconstruction")) return Cancelled();
    const bool common = AnyFlagged(r.fit.status) || !r.fit.views.empty();
    const StackScore score =
        ScoreFit(*stack, r.fit, false, stages.Callback(),
                 {.reconstruction = true, .residuals = false, .common = common});
    r.reconstruction = score.reconstruction;
    r.reconstruction_common = common ? score.reconstruction_common : r.reconstruction;
    stages.End();
    const std::string truth_dir = synth::FindTruthFolder(o.input);
    if (!truth_dir.empty()) {
      if (!stages.Begin("truth")) return Cancelled();
      if (auto truth = TruthOfRegion(synth::ReadTruth(truth_dir, o.read.confine_to), *stack);
          truth.ok() && truth->width == stack->width())
        r.truth = CompareToTruth(r.fit.maps, *truth, r.fit.status);
      stages.End();
    }
    r.timings = stages.Snapshot();
    FitReportInputs ri;
    ri.result = &r.fit;
    ri.images = r.images;
    ri.reconstruction = r.reconstruction;
    ri.reconstruction_common = r.reconstruction_common;
    ri.truth = r.truth;
    ri.source = o.source_label.empty() ? o.input : o.source_label;
    ri.crop = CropRegion(*stack);
    ri.timings = &r.timings;
    ri.tone = r.tone ? &*r.tone : nullptr;
    ri.read_encoding = r.read_encoding;
    r.report_json = MakeReportJson(ri);
    if (!o.out.empty()) MATFIT_RETURN_IF_ERROR(WriteFileAtomic(o.out, r.report_json));
    return r;
  }
  std::optional<Selection> selection;
  std::string model = o.model;
  if (model == "auto") {
    if (!stages.Begin("select")) return Cancelled();
    // A multi-view stack: only the views the scene shows (scene.json view_theta_max_deg).
    const int views_in_data = int(ViewGroups(*stack).size());
    if (stack->is_multi_view() && scene.view_theta_max_deg < 90) {
      *stack = ScenesViews(*stack, scene);
      diagnosis.reset();
    }
    SelectOptions so;
    so.fit.progress = stages.Callback();
    auto sel = SelectModel(*stack, scene, so);
    if (!sel.ok()) return sel.status();
    selection = std::move(*sel);
    selection->views_in_data = views_in_data;
    selection->views = int(ViewGroups(*stack).size());
    if (selection->views < views_in_data) {
      char note[200];
      std::snprintf(note, sizeof note,
                    "the scene shows views up to θv %g° (view_theta_max_deg): %d of the data's %d "
                    "views fitted",
                    scene.view_theta_max_deg, selection->views, views_in_data);
      selection->warnings.push_back(Warning(WarningCode::kViewsOutsideScene, note));
    }
    model = selection->method;
    // The same two steps as the selection scored: to the scene's level, then to the maps'.
    for (int f : {1 << selection->scene_level, 1 << (selection->level - selection->scene_level)}) {
      if (f == 1) continue;
      auto small = DownsampleStack(*stack, f);
      if (!small.ok()) return small.status();
      *stack = std::move(*small);
      diagnosis.reset();  // a new stack: the assessment diagnoses it
    }
    if (selection->level > 0)
      selection->warnings.push_back(Warning(
          WarningCode::kPackAtMip,
          "the pack is at mip " + std::to_string(selection->level) + " (1/" +
              std::to_string(1 << selection->level) +
              " of the dataset's resolution): its reconstruction and held-out figures are at that "
              "resolution; truth maps and --report-only compare at the dataset's"));
    stages.End();
  }
  const auto method = MakeMethod(model);
  if (!stages.Begin("fit")) return Cancelled();
  FitOptions fo = o.fit;
  fo.progress = stages.Callback();
  auto fit = method->Fit(*stack, fo);
  if (!fit.ok()) return fit.status();
  stages.End();

  r.images = stack->num_images();
  // One pass predicts every image: the reconstruction metrics and the bound's residual sums.
  // A per-view fit predicts each view's images from its own maps (fit/per_view_fit.h).
  const bool per_view = !fit->views.empty();
  if (!stages.Begin("reconstruction")) return Cancelled();
  // The common texel set differs only when the fit flagged texels: then its figures come from
  // the same pass (ScoreParts::common).
  bool flagged = AnyFlagged(*stack, fit->status);
  for (const ViewFit& v : fit->views) flagged = flagged || AnyFlagged(*stack, v.status);
  StackScore score = ScoreFit(*stack, *fit, false, stages.Callback(),
                              {.reconstruction = true, .residuals = !per_view, .common = flagged});
  r.reconstruction = score.reconstruction;
  r.reconstruction_common = flagged ? score.reconstruction_common : r.reconstruction;
  stages.End();
  std::vector<uint8_t> fitted_status = fit->status;  // metrics describe what was fitted
  if (!stages.Begin("confidence")) return Cancelled();
  if (per_view) {
    // The pack's own maps are the most frontal view's: their bound, from that view's images.
    const LightStack front = SelectView(*stack, ViewGroups(*stack)[size_t(fit->frontal_view)]);
    r.assessment = AssessFit(front, *PerViewBase(*method), &*fit, {}, stages.Callback(), nullptr,
                             diagnosis ? &*diagnosis : nullptr);
  } else {
    r.assessment = AssessFit(*stack, *method, &*fit, {}, stages.Callback(), &score.residuals,
                             diagnosis ? &*diagnosis : nullptr);
  }
  with_dataset_warnings(&fit->warnings);
  stages.End();
  if (selection) {
    for (const auto& w : selection->warnings) fit->warnings.push_back(w);  // coded already
    r.selection = selection;
  }
  if (o.holdout >= 2 || o.holdout == kLeaveOneOut) {
    if (!stages.Begin("heldout", o.holdout == kLeaveOneOut ? stack->num_images() : o.holdout))
      return Cancelled();
    FitOptions ho = o.fit;
    ho.progress = stages.Callback();
    auto h = HeldOut(*method, *stack, o.holdout, ho);
    if (!h.ok()) return h.status();
    r.heldout = std::move(*h);
    if (!comm) {  // distributed: once rank 0 has every band's texels (below)
      r.bound_ratio_heldout =
          BoundToActualRatio(r.assessment.confidence.bound, r.heldout->texel_rmse, fit->status);
      r.heldout->texel_rmse = {};  // not kept: the ratio is what the report needs
    }
    stages.End();
  }
  if (o.holdout_views > 0) {
    if (!stages.Begin("heldout-views")) return Cancelled();
    FitOptions ho = o.fit;
    ho.progress = stages.Callback();
    auto h = HeldOutViews(*method, *stack, o.holdout_views, ho);
    if (!h.ok()) return h.status();
    r.heldout_views = std::move(*h);
    stages.End();
  }
  // Collective under MPI (ScoreStack reduces over the bands, every rank in the same order).
  if (stack->is_multi_view())
    r.deviation_by_view_theta = per_view ? DeviationByViewTheta(*stack, *fit)
                                         : DeviationByViewTheta(*stack, fit->maps, fitted_status);
  if (!o.pca_components.empty() && stack->is_multi_view() && !comm) {
    if (!stages.Begin("pca")) return Cancelled();
    r.per_view_pca = PerViewPcaCurve(*stack, o.pca_components, fitted_status, stages.Callback());
    stages.End();
    if (!o.out.empty()) {  // the largest k, stored in the pack
      if (!stages.Begin("pca-store")) return Cancelled();
      r.per_view_pca_models = PerViewPcaModels(
          *stack, *std::max_element(o.pca_components.begin(), o.pca_components.end()),
          fitted_status, stages.Callback());
      stages.End();
    }
  }
  if (comm) {
    // Every figure so far is the whole stack's (each step reduced over the bands); the per-texel
    // results go to rank 0, which scores against truth and writes the pack. The other ranks
    // wait for its outcome.
    (void)stages.Begin("gather");  // timed; not cancellable (the ranks must stay in step)
    GatherMaps(*comm, stack->full_height(), &fit->maps);
    GatherPlane(*comm, &fit->status);
    for (ViewFit& v : fit->views) {  // a per-view fit: every view's band
      GatherMaps(*comm, stack->full_height(), &v.maps);
      GatherPlane(*comm, &v.status);
    }
    GatherPlane(*comm, &fitted_status);
    GatherPlane(*comm, &r.assessment.confidence.bound);
    if (r.heldout) GatherPlane(*comm, &r.heldout->texel_rmse);
    int64_t counts[3] = {!fit->dropped_lights.empty(), fit->refit_texels, fit->dropped_samples};
    SumAcross(*comm, counts, 3);
    fit->refit_texels = counts[1], fit->dropped_samples = counts[2];
    if (counts[0] > 0) {  // a band without refitted texels has no plane of its own
      if (fit->dropped_lights.empty()) fit->dropped_lights.assign(size_t(stack->plane_size()), 0);
      GatherPlane(*comm, &fit->dropped_lights);
    }
    stages.End();
    if (comm->rank() != 0) {
      std::string failed;
      if (!AllOk(*comm, true, "", &failed))
        return Status(StatusCode::kInternal, "rank 0: " + failed);
      r.fit = std::move(*fit);
      r.timings = stages.Snapshot();
      return r;
    }
    if (r.heldout) {
      r.bound_ratio_heldout =
          BoundToActualRatio(r.assessment.confidence.bound, r.heldout->texel_rmse, fit->status);
      r.heldout->texel_rmse = {};
    }
  }
  // Rank 0 (or the only process) finishes; the other ranks learn its outcome. What is left needs
  // the maps and the stack's description, not its samples: their memory goes back before the
  // pack's buffers are allocated (a lower peak, and pages the system has just had back).
  stack->ReleaseSamples();
  const Status finished =
      FinishJob(o, *stack, *method, selection, scene, fitted_status, std::move(*fit), &stages, &r);
  if (comm) {
    std::string failed;
    AllOk(*comm, finished.ok(), finished.ok() ? "" : finished.message(), &failed);
  }
  if (!finished.ok()) return finished;
  r.timings = stages.Snapshot();
  return r;
}

}  // namespace matfit::fit
