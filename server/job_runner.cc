#include "server/job_runner.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/color.h"
#include "core/dataset/dataset.h"
#include "fit/fit_job.h"
#include "leaf/leaf_job.h"
#include "leaf/scan.h"
#include "render/cpu_renderer.h"
#include "server/api_wording.h"
#include "server/text.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Share of the whole job each stage takes (measured roughly on the fixtures), in order; the
// stages of fit::RunFitJob (fit/fit_job.h) and leaf::RunLeafJob. model=auto adds the selection
// (several fits per candidate) before the final fit. Without held-out folds or truth the job
// jumps over their spans.
const std::map<std::string, std::pair<double, double>>& StageSpans(bool leaf, bool select,
                                                                   bool views) {
  // Every view of a BTF (view=all): the svbrdf fit dominates; out of core, the headers, the band
  // cache and the frontal start come between read and fit.
  static const std::map<std::string, std::pair<double, double>> multi_view = {
      {"read", {0.0, 0.05}},           {"cache", {0.05, 0.12}},
      {"start", {0.12, 0.14}},         {"fit", {0.14, 0.85}},
      {"reconstruction", {0.85, 0.9}}, {"confidence", {0.9, 0.92}},
      {"truth", {0.92, 0.95}},         {"write", {0.95, 1}}};
  static const std::map<std::string, std::pair<double, double>> fit = {
      {"read", {0.0, 0.1}},       {"fit", {0.1, 0.35}},     {"reconstruction", {0.35, 0.5}},
      {"confidence", {0.5, 0.6}}, {"heldout", {0.6, 0.93}}, {"truth", {0.93, 0.95}},
      {"write", {0.95, 1}}};
  static const std::map<std::string, std::pair<double, double>> autofit = {
      {"read", {0.0, 0.05}},       {"select", {0.05, 0.75}},
      {"fit", {0.75, 0.82}},       {"reconstruction", {0.82, 0.86}},
      {"confidence", {0.86, 0.9}}, {"heldout", {0.9, 0.97}},
      {"truth", {0.97, 0.98}},     {"write", {0.98, 1}}};
  static const std::map<std::string, std::pair<double, double>> lf = {
      {"read", {0.0, 0.1}}, {"sheet", {0.1, 0.4}}, {"leaves", {0.4, 0.95}}, {"write", {0.95, 1}}};
  return leaf ? lf : select ? autofit : views ? multi_view : fit;
}

bool Forward(const JobProgress& p, bool leaf, bool select, bool views, const std::string& stage,
             int64_t done, int64_t total) {
  if (!p) return true;
  const auto& spans = StageSpans(leaf, select, views);
  const auto it = spans.find(stage);
  const auto [a, b] = it == spans.end() ? std::pair<double, double>{0, 1} : it->second;
  const double f = total > 0 ? std::clamp(double(done) / double(total), 0.0, 1.0) : 0.0;
  return p(a + (b - a) * f, stage);
}

bool HasFileMatching(const std::string& dir, const std::vector<std::string>& needles) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    for (const auto& k : needles)
      if (n.find(k) != std::string::npos) return true;
  }
  return false;
}

std::optional<ViewAngles> ViewOf(const JobSpec& spec) {
  if (spec.view.empty() || spec.view == "all") return std::nullopt;
  ViewAngles v;
  std::sscanf(spec.view.c_str(), "%lf,%lf", &v.theta_deg, &v.phi_deg);
  return v;
}

std::vector<std::string> ForApi(std::vector<std::string> messages) {
  for (auto& m : messages) m = ApiWording(std::move(m));
  return messages;
}

}  // namespace

ReadOptions JobReadOptions(const JobSpec& spec) {
  ReadOptions ro;
  ro.view = ViewOf(spec);
  ro.all_views = spec.view == "all";  // every view of a BTF (model svbrdf or auto)
  if (!ParseLayout(spec.layout, &ro.layout)) ro.layout = Layout::kAuto;  // checked at parse
  if (!ParseColorSpaceChoice(spec.color_space, &ro.color_space))
    ro.color_space = ColorSpaceChoice::kAuto;
  return ro;
}

Status ValidateDataset(const JobSpec& spec, const std::string& dir, int64_t max_stack_samples,
                       std::string* field) {
  std::string unused;
  if (!field) field = &unused;
  *field = "";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return NotFound("dataset folder '" + dir + "' does not exist");
  if (spec.mode == "leaf") {
    if (!fs::exists(fs::path(dir) / "leaf.json", ec) && !HasFileMatching(dir, {"_BL.", "back"}))
      return DataError(
          "the upload is not a leaf scan: it has no leaf.json and no back-lit images (*_BL.png "
          "or *back*.png)");
    leaf::LeafScanReadOptions o;
    o.confine = true;
    o.max_samples = max_stack_samples;
    o.headers_only = true;
    auto scan = leaf::ReadLeafScan(dir, o);
    return scan.ok() ? Status::Ok() : scan.status();
  }
  // The job's own read, files and headers only: what would fail the job fails the submission.
  ReadOptions ro = JobReadOptions(spec);
  ro.confine_to = dir;
  ro.max_stack_samples = max_stack_samples;
  ro.headers_only = true;
  auto stack = ReadDataset(dir, ro);
  if (!stack.ok()) {
    const std::string& m = stack.status().message();
    // The files of two layouts (DetectLayout): the layout field resolves it; a bad view names
    // the view field; anything else is about the uploaded files.
    *field = m.find(" layouts: ") != std::string::npos ? "layout"
             : m.find("--view") != std::string::npos   ? "view"
                                                       : "";
    return stack.status();
  }
  const int images = int(stack->lights().size());
  if (spec.holdout > images)
    return *field = "holdout",
           InvalidArgument("field 'holdout': " + std::to_string(spec.holdout) +
                           " folds need at least as many images, the dataset has " +
                           std::to_string(images) + "; use a holdout of 2.." +
                           std::to_string(images) + " or 0 (off)");
  if (spec.holdout == fit::kLeaveOneOut && images < 3)
    return *field = "holdout",
           InvalidArgument(
               "field 'holdout': leave-one-out fits on all images but one and needs "
               "at least 3 images, the dataset has " +
               std::to_string(images) + "; use 0 (off)");
  if (spec.model == "auto" && images < 3)
    return *field = "model",
           InvalidArgument(
               "field 'model': auto scores models on held-out lights and needs at "
               "least 3 images, the dataset has " +
               std::to_string(images) + "; name a model (e.g. lambert)");
  return Status::Ok();
}

StatusOr<std::string> RunJob(const JobSpec& spec, const std::string& dataset,
                             const std::string& out_dir, const JobProgress& progress,
                             const std::string& source_label, int64_t max_stack_samples) {
  const bool leaf = spec.mode == "leaf", select = spec.model == "auto", views = spec.view == "all";
  auto stage = [&](const std::string& s, int64_t d, int64_t t) {
    return Forward(progress, leaf, select, views, s, d, t);
  };
  if (leaf) {
    leaf::LeafJobOptions o;
    o.input = dataset;
    o.source_label = source_label;
    o.out = out_dir;
    o.overwrite = true;
    o.confine = true;
    o.max_stack_samples = max_stack_samples;
    o.preview = [](const MaterialMaps& m, bool behind) {  // as `matfit leaf` does
      return render::RenderLeafPreview(m, behind, 256);
    };
    auto r = leaf::RunLeafJob(o, stage);
    if (!r.ok()) return r.status();
    json leaves = json::array();
    for (const auto& s : r->summary)
      leaves.push_back({{"id", s.id},
                        {"name", s.name},
                        {"area_px", s.area_px},
                        {"mean_hl2_error", s.mean_hl2_error}});
    return JsonText(json{{"mode", "leaf"},
                         {"leaves", r->leaves},
                         {"twigs", r->twigs},
                         {"markers", r->markers},
                         {"mm_per_pixel", r->mm_per_pixel},
                         {"scale_source", r->scale_source},
                         {"seconds", r->seconds_total},
                         {"packs", leaves},
                         {"warnings", ForApi(r->warnings)}});
  }
  fit::FitJobOptions o;
  o.input = dataset;
  o.source_label = source_label;
  o.model = spec.model;
  o.holdout = spec.holdout;
  o.budget = spec.budget;
  o.out = out_dir;
  o.overwrite = true;
  o.read = JobReadOptions(spec);
  o.read.confine_to = dataset;
  o.read.max_stack_samples = max_stack_samples;
  // A multi-view job over the memory budget streams through a band cache: in the job's own folder
  // (beside its pack, on the server's data disk and removed with the cache), not in /tmp.
  if (o.read.all_views) o.cache_dir = fs::path(out_dir).parent_path().string();
  auto r = fit::RunFitJob(o, stage);
  if (!r.ok()) return r.status();
  json s = {{"mode", "fit"},
            {"method", r->fit.method},
            {"texels", int64_t(r->fit.maps.width) * r->fit.maps.height},
            {"images", r->images},
            {"fit_seconds", r->fit.fit_seconds},
            {"flagged_texels", r->fit.flagged_texels},
            {"rmse", r->reconstruction.rmse},
            {"psnr_db", r->reconstruction.psnr_db},
            {"deviation_percent", r->reconstruction.deviation_percent},
            {"warnings", ForApi(r->fit.warnings)}};
  if (r->heldout) {
    s["heldout_rmse"] = r->heldout->rmse;
    s["heldout_folds"] = r->heldout->folds;
    if (std::isfinite(r->heldout->psnr_srgb8_db))
      s["heldout_psnr_srgb8_db"] = r->heldout->psnr_srgb8_db;
  }
  if (r->truth && r->truth->has_normal) s["normal_mae_deg"] = r->truth->normal_mae_deg;
  return JsonText(s);
}

}  // namespace matfit::server
