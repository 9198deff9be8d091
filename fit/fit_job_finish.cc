#include "fit/fit_job_finish.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "core/pack/pack.h"
#include "core/path_util.h"
#include "core/synth/truth_io.h"
#include "core/warnings.h"
#include "fit/confidence.h"
#include "fit/metrics.h"
#include "fit/per_view_pca.h"

namespace matfit::fit::job {
namespace {

// --components: the per-view PCA at the largest k as the pack's pca/ folder (docs/pack.md
// "Per-view PCA"): per view its weights and basis (float EXR), and pca/pca.json.
void AddPcaFiles(const LightStack& stack, std::vector<ViewPcaModel>* models, PackInfo* info) {
  nlohmann::json views = nlohmann::json::array();
  int k = 0;
  for (size_t v = 0; v < models->size(); ++v) {
    ViewPcaModel& m = (*models)[v];
    char name[32];
    std::snprintf(name, sizeof name, "pca/v%03u", unsigned(v));
    nlohmann::json lights = nlohmann::json::array();
    for (int i : m.images) {
      const LightSample& l = stack.lights()[size_t(i)];
      lights.push_back({{"direction", {l.direction.x, l.direction.y, l.direction.z}},
                        {"intensity", {l.intensity.x, l.intensity.y, l.intensity.z}}});
    }
    k = std::max(k, m.weights.channels());
    views.push_back({{"theta_deg", m.theta_deg},
                     {"phi_deg", m.phi_deg},
                     {"k", m.weights.channels()},
                     {"weights", std::string(name) + "_weights.exr"},
                     {"basis", std::string(name) + "_basis.exr"},
                     {"lights", lights}});
    info->extra_files.push_back({std::string(name) + "_weights.exr",
                                 "per-view PCA weights (k channels per texel)",
                                 std::move(m.weights),
                                 {}});
    info->extra_files.push_back({std::string(name) + "_basis.exr",
                                 "per-view PCA mean (row 0) and components (rows 1..k)",
                                 std::move(m.basis),
                                 {}});
  }
  const nlohmann::json j = {
      {"schema", "matfit.pca/1"},
      {"k", k},  // the largest; a view with fewer samples holds min(k, L·C) (its own "k")
      {"channels", stack.channels()},
      {"sample",
       "I[a][c] * (basis[0][a*C + c] + sum_j weights[j](x) * basis[j][a*C + c]) for image a of the "
       "view (its lights, in order), channel c, texel x; linear"},
      {"views", views}};
  info->extra_files.push_back({"pca/pca.json",
                               "per-view PCA reference (Sattler 2003): views, lights, files",
                               {},
                               j.dump(2) + "\n"});
}

}  // namespace

StatusOr<MaterialMaps> TruthOfRegion(StatusOr<MaterialMaps> truth, const LightStack& stack) {
  if (!truth.ok() || !stack.is_read_crop() || truth->width != stack.source_width ||
      truth->height != stack.source_height)
    return truth;
  return CropMaps(*truth, stack.crop_x, stack.crop_y, stack.crop_w, stack.crop_h);
}

std::optional<FitReportInputs::Region> CropRegion(const LightStack& s) {
  if (s.crop_w <= 0) return std::nullopt;
  return FitReportInputs::Region{s.crop_x, s.crop_y,       s.crop_w,
                                 s.crop_h, s.source_width, s.source_height};
}

Status FinishJob(const FitJobOptions& o, const LightStack& stack, const FitMethod& method,
                 const std::optional<Selection>& selection, const SceneSpec& scene,
                 const std::vector<uint8_t>& fitted_status, FitResult fit, Stages* stages,
                 FitJobResult* out) {
  FitJobResult& r = *out;
  const std::string truth_dir = synth::FindTruthFolder(o.input);
  if (!truth_dir.empty()) {
    if (!stages->Begin("truth")) return Cancelled();
    auto truth = TruthOfRegion(synth::ReadTruth(truth_dir, o.read.confine_to), stack);
    if (truth.ok() && truth->width == stack.width() && truth->height == stack.full_height()) {
      r.truth = CompareToTruth(fit.maps, *truth, fitted_status);
      // The bound claims the supported cone within the recorded range: scored there, as the
      // stability matrix does. Only where relighting the truth maps gives the true appearance
      // (not micro-geometry truth).
      const Confidence& c = r.assessment.confidence;
      if (!c.bound.empty() && synth::TruthMapsAreTheAppearance(truth_dir, o.read.confine_to))
        r.bound_ratio_truth = BoundToActualRatio(
            c.bound,
            RelightingError(fit.maps, *truth,
                            DomeDirections(48, c.supported_theta_deg, c.supported_axis),
                            stack.view_direction, c.recorded_limit),
            fit.status);
    } else
      fit.warnings.push_back(
          Warning(WarningCode::kTruthUnusable,
                  "truth folder '" + DatasetRelative(truth_dir, o.read.confine_to) +
                      "' could not be used: " +
                      (truth.ok() ? std::string("size differs") : truth.status().message())));
    stages->End();
  }
  r.fit = std::move(fit);

  if (!stages->Begin("write")) return Cancelled();
  FitReportInputs ri;
  ri.result = &r.fit;
  ri.parameters_per_texel = method.parameters_per_texel();
  // A per-view pack stores the base model's maps once per view.
  ri.bytes_per_texel = method.bytes_per_texel() * std::max<int>(1, int(r.fit.views.size()));
  ri.images = r.images;
  ri.reconstruction = r.reconstruction;
  ri.reconstruction_common = r.reconstruction_common;
  ri.heldout = r.heldout;
  ri.heldout_views = r.heldout_views;
  ri.deviation_by_view_theta = r.deviation_by_view_theta;
  ri.per_view_pca = r.per_view_pca;
  ri.truth = r.truth;
  // An out-of-core fit has no assessment (no bound, no diagnosis): report.json says null.
  ri.assessment = r.assessment.confidence.bound.empty() ? nullptr : &r.assessment;
  ri.tone = r.tone ? &*r.tone : nullptr;
  ri.read_encoding = r.read_encoding;
  ri.bound_ratio_heldout = r.bound_ratio_heldout;
  ri.bound_ratio_truth = r.bound_ratio_truth;
  if (selection) ri.selection_json = SelectionJson(*selection, scene);
  ri.source = o.source_label.empty() ? o.input : o.source_label;
  ri.crop = CropRegion(stack);
  r.report_json = MakeReportJson(ri);  // for material.json's summary; timed again below

  PackInfo info;
  info.method = r.fit.method;
  info.source = ri.source;
  info.report_json = r.report_json;
  // report.json is the pack's last file: its timings include the write up to that point.
  info.final_report_json = [&] {
    r.timings = stages->Snapshot(/*running=*/true);
    ri.timings = &r.timings;
    r.report_json = MakeReportJson(ri);
    return r.report_json;
  };
  info.model_parameters = r.fit.parameters;
  info.mm_per_texel = stack.mm_per_texel;
  info.warnings = r.fit.warnings;
  if (!r.assessment.confidence.bound.empty()) {  // none for an out-of-core fit
    Image bound(stack.width(), stack.full_height(), 1);
    std::copy(r.assessment.confidence.bound.begin(), r.assessment.confidence.bound.end(),
              bound.Plane(0).begin());
    info.extra_maps.push_back({"confidence", "confidence.exr",
                               "per-texel bound on the RMS relighting error (linear, per unit "
                               "light; +inf = flagged), docs/stability.md",
                               std::move(bound)});
  }
  if (!r.fit.dropped_lights.empty()) {
    Image dropped(stack.width(), stack.full_height(), 1);
    for (size_t p = 0; p < r.fit.dropped_lights.size(); ++p)
      dropped.data()[p] = float(std::min<int>(r.fit.dropped_lights[p], 255)) / 255.0f;
    info.extra_maps.push_back({"dropped", "dropped.png",
                               "per texel, the lights whose clipped or non-finite samples the "
                               "fit dropped (8-bit count, 255 = 255 or more)",
                               std::move(dropped)});
  }
  for (const ViewFit& v : r.fit.views)
    info.views.push_back({v.theta_deg, v.phi_deg, &v.maps, &v.status, &v.parameters});
  if (!r.per_view_pca_models.empty()) AddPcaFiles(stack, &r.per_view_pca_models, &info);
  PackWriteOptions write{o.zip, o.overwrite, o.compact_maps};
  write.progress = stages->Callback();
  MATFIT_RETURN_IF_ERROR(WritePack(r.fit.maps, r.fit.status, info, write, o.out));
  stages->End();
  return Status::Ok();
}

}  // namespace matfit::fit::job
