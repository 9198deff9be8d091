#include "fit/report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "core/version.h"

namespace matfit::fit {
namespace {

using nlohmann::json;

json Finite(double v) { return std::isfinite(v) ? json(v) : json(); }

json ByTheta(const std::map<int, double>& m) {
  json j = json::object();
  for (const auto& [t, d] : m) j[std::to_string(t)] = d;
  return j;
}

}  // namespace

std::string MakeReportJson(const FitReportInputs& in) {
  const FitResult& r = *in.result;
  // Counted per code, then named: a name lookup per texel was a serial ~5 ms per report.
  std::array<int64_t, 256> per_code{};
  for (uint8_t s : r.status) ++per_code[s];
  std::map<std::string, int64_t> counts;
  for (int s = 0; s < 256; ++s)
    if (per_code[size_t(s)] > 0) counts[TexelStatusName(uint8_t(s))] += per_code[size_t(s)];
  json params = json::object();
  for (const auto& [k, v] : r.parameters) params[k] = v;
  json j = {
      {"generator", std::string("matfit ") + kMatfitVersion},  // --force recognises it
      {"method", r.method},
      {"model", ShadingModelName(r.maps.model)},
      {"source", in.source},
      {"crop", in.crop ? json({{"x", in.crop->x},
                               {"y", in.crop->y},
                               {"width", in.crop->width},
                               {"height", in.crop->height},
                               {"source_width", in.crop->source_width},
                               {"source_height", in.crop->source_height}})
                       : json()},
      {"fit_seconds", r.fit_seconds},
      {"texels", int64_t(r.maps.width) * r.maps.height},
      {"images", in.images},
      {"parameters_per_texel", in.parameters_per_texel},
      {"bytes_per_texel", in.bytes_per_texel},
      {"deviation_percent", in.reconstruction.deviation_percent},
      {"deviation_percent_by_theta", ByTheta(in.reconstruction.deviation_percent_by_theta)},
      {"rmse", in.reconstruction.rmse},
      {"psnr_db", Finite(in.reconstruction.psnr_db)},
      {"rmse_common", in.reconstruction_common.rmse},
      {"psnr_db_common", Finite(in.reconstruction_common.psnr_db)},
      {"flagged_texels", r.flagged_texels},
      {"refit_texels", r.refit_texels},
      {"dropped_samples", r.dropped_samples},
      {"status_counts", counts},
      {"parameters", params},
      {"warnings", r.warnings},
      {"heldout", nullptr},
  };
  // Multi-view stacks (issue 17): dev% per (θv, θl) group, and the held-out views.
  json by_view = json::object();
  for (const auto& [tv, m] : in.deviation_by_view_theta) by_view[std::to_string(tv)] = ByTheta(m);
  j["deviation_percent_by_view_theta"] =
      in.deviation_by_view_theta.empty() ? json() : json(by_view);
  json pca = json::array();  // the per-view PCA reference (--components)
  for (const PcaPoint& pt : in.per_view_pca)
    pca.push_back({{"k", pt.k}, {"bytes_per_texel", pt.bytes_per_texel}, {"rmse", pt.rmse}});
  j["per_view_pca"] = in.per_view_pca.empty() ? json() : pca;
  j["heldout_views"] = nullptr;
  if (in.heldout_views) {
    const HeldOutViewMetrics& h = *in.heldout_views;
    json views = json::array();
    for (const HeldOutView& v : h.views)
      views.push_back(
          {{"theta_deg", v.theta_deg},
           {"phi_deg", v.phi_deg},
           {"rmse", v.metrics.rmse},
           {"deviation_percent", v.metrics.deviation_percent},
           {"deviation_percent_by_theta", ByTheta(v.metrics.deviation_percent_by_theta)},
           {"psnr_db", Finite(v.metrics.psnr_db)}});
    j["heldout_views"] = {{"views", views},
                          {"train_views", h.train_views},
                          {"rmse", h.all.rmse},
                          {"deviation_percent", h.all.deviation_percent},
                          {"psnr_db", Finite(h.all.psnr_db)},
                          {"psnr_srgb8_db", Finite(h.all.psnr_srgb8_db)},
                          {"samples", h.all.samples}};
  }
  if (in.heldout) {
    const HeldOutMetrics& h = *in.heldout;
    j["heldout"] = {{"folds", h.folds},
                    {"rmse", h.rmse},
                    {"deviation_percent", h.deviation_percent},
                    {"deviation_percent_by_theta", ByTheta(h.deviation_percent_by_theta)},
                    {"psnr_db", Finite(h.psnr_db)},
                    {"rmse_common", h.rmse_common},
                    {"psnr_db_common", Finite(h.psnr_db_common)},
                    {"rmse_srgb8", Finite(h.rmse_srgb8)},
                    {"psnr_srgb8_db", Finite(h.psnr_srgb8_db)},
                    {"rmse_srgb8_common", Finite(h.rmse_srgb8_common)},
                    {"psnr_srgb8_db_common", Finite(h.psnr_srgb8_db_common)},
                    {"failed_folds", h.failed_folds}};
  }
  if (in.assessment) {
    const Confidence& c = in.assessment->confidence;
    std::vector<float> b(c.bound.size());  // the finite bounds (one allocation, no regrowth)
    b.resize(size_t(std::copy_if(c.bound.begin(), c.bound.end(), b.begin(),
                                 [](float v) { return std::isfinite(v); }) -
                    b.begin()));
    double median = NAN;
    if (!b.empty()) {
      std::nth_element(b.begin(), b.begin() + b.size() / 2, b.end());
      median = b[b.size() / 2];
    }
    j["confidence"] = {
        {"pooled_sigma", Finite(c.pooled_sigma)},
        {"extrapolation", Finite(c.extrapolation)},
        {"supported_theta_deg", c.supported_theta_deg},
        {"supported_axis", {c.supported_axis.x, c.supported_axis.y, c.supported_axis.z}},
        {"bound_median", Finite(median)},
        {"unverifiable_texels", c.unverifiable},
        {"recorded_limit", IsFinite(c.recorded_limit)
                               ? json{c.recorded_limit.x, c.recorded_limit.y, c.recorded_limit.z}
                               : json()},
        {"saturated_texels", c.saturated}};
    const auto ratio = [](const std::optional<BoundRatio>& tight) {
      return tight ? json{{"median", Finite(tight->median)},
                          {"p90", Finite(tight->p90)},
                          {"texels", tight->texels},
                          {"exceeded_fraction", Finite(tight->exceeded_fraction)}}
                   : json();
    };
    j["confidence"]["bound_ratio"] = {{"heldout", ratio(in.bound_ratio_heldout)},
                                      {"truth", ratio(in.bound_ratio_truth)}};
    const StackDiagnostics& d = in.assessment->diagnostics;
    j["diagnostics"] = {{"encoding_exponent", d.encoding_exponent},
                        {"tone_verdict", ToneVerdictName(d.verdict)},
                        {"tone_evidence", d.evidence},
                        {"looks_gamma_encoded", d.looks_gamma_encoded},
                        {"looks_linear_read_as_srgb", d.looks_linear_read_as_srgb},
                        {"residual_linear", d.residual_linear},
                        {"residual_best", d.residual_best},
                        {"residual_srgb_decoded", d.residual_srgb_decoded},
                        {"residual_srgb_encoded", d.residual_srgb_encoded}};
  }
  if (!in.read_encoding.empty()) j["diagnostics"]["read_as"] = in.read_encoding;
  if (in.tone)
    j["diagnostics"]["tone_correction"] =
        in.tone->corrected ? json{{"from", in.tone->from.ToString()},
                                  {"from_reason", in.tone->from_reason},
                                  {"to", in.tone->to.ToString()},
                                  {"gamma_before", in.tone->before.encoding_exponent},
                                  {"evidence_before", in.tone->before.evidence}}
                           : json();
  if (in.timings) {
    json t = json::object();
    for (const auto& [stage, seconds] : in.timings->stages) t[stage] = seconds;
    t["total"] = in.timings->total;
    j["timings"] = t;
  }
  if (!in.selection_json.empty()) j["selection"] = json::parse(in.selection_json);
  if (in.truth) {
    // null where the model has no such map (see TruthMetrics).
    j["normal_mae_deg"] = in.truth->has_normal ? json(in.truth->normal_mae_deg) : json();
    j["normal_p95_deg"] = in.truth->has_normal ? json(in.truth->normal_p95_deg) : json();
    j["albedo_rmse"] = in.truth->has_albedo ? json(in.truth->albedo_rmse) : json();
    j["truth_texels"] = in.truth->texels;
    j["parameter_errors"] = in.truth->parameter_errors;
  }
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace matfit::fit
