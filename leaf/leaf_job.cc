#include "leaf/leaf_job.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/comm.h"
#include "core/image_io.h"
#include "core/output_marker.h"
#include "core/pack/pack.h"
#include "core/version.h"
#include "core/warnings.h"
#include "fit/fit_types.h"
#include "leaf/overlay.h"
#include "leaf/scan.h"

namespace matfit::leaf {

namespace fs = std::filesystem;
using nlohmann::json;

bool LeafJobOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (input.empty()) return fail("the leaf-scan folder is empty");
  if (out.empty()) return fail("--out DIR is required");
  if (max_stack_samples < 0)
    return fail("the scan's sample limit must be ≥ 0 (0 = none), got " +
                std::to_string(max_stack_samples));
  auto num = [](double v) { return std::to_string(v); };
  if (mm_per_pixel != 0 && !(mm_per_pixel >= 1e-3 && mm_per_pixel <= 100))
    return fail("--mm-per-pixel must be in [0.001, 100], got " + num(mm_per_pixel));
  if (marker_size_mm < 0 || marker_size_mm > 1000)
    return fail("--marker-size-mm must be in (0, 1000], got " + num(marker_size_mm));
  if (max_thickness_mm < 0 || max_thickness_mm > 10)
    return fail("--max-thickness-mm must be in (0, 10], got " + num(max_thickness_mm));
  if (!(default_mm_per_pixel >= 1e-3 && default_mm_per_pixel <= 100))
    return fail("default mm per pixel must be in [0.001, 100], got " + num(default_mm_per_pixel));
  if (only_leaf < 0) return fail("--leaf must be ≥ 1, got " + std::to_string(only_leaf));
  if (crop && (crop->x < 0 || crop->y < 0 || crop->w <= 0 || crop->h <= 0))
    return fail("--crop needs x,y ≥ 0 and a width and height > 0");
  return sheet.Check(why) && material.Check(why);
}

namespace {

double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

json Bbox(const Component& c) { return {c.x0, c.y0, c.x1 - c.x0 + 1, c.y1 - c.y0 + 1}; }

std::string LeafReport(const LeafMaterial& L, const LeafMaterialOptions& o, int64_t flagged) {
  json e = json::array();
  const double el[3] = {1.5707963267948966, 0.7853981633974483, 0.39269908169872414};
  for (int k = 0; k < 3; ++k)
    e.push_back({{"elevation_rad", el[k]},
                 {"mean_percent", 100 * L.hl2_error[k].mean},
                 {"texel_directions", L.hl2_error[k].texels},
                 {"histogram_percent_bins", {"<1", "1-2", "2-5", "5-10", "10-20", ">=20"}},
                 {"histogram", L.hl2_error[k].histogram}});
  json r = {
      {"schema", "matfit.leaf-report/1"},
      {"leaf", L.component.id},
      {"size", {{"width", L.maps.width}, {"height", L.maps.height}}},
      {"mm_per_texel", L.mm_per_texel},
      {"area_px", L.component.area_px},
      {"translucency",
       {{"method", o.reference_precompute ? "reference" : "fast"},
        {"directions", o.translucency.directions},
        {"kernel_radius_texels", L.translucency.kernel_radius},
        {"kernel_terms", L.translucency.kernel_terms},
        {"kernel_error", L.translucency.kernel_error},
        {"thin_texels", L.translucency.thin_texels},
        {"hl2_vs_multipole", e}}},
      {"thickness_estimated", L.thickness_estimated},
      {"specular_fitted", L.specular_fitted},
      {"flagged_texels", flagged},
      {"timings_seconds",
       {{"maps", L.seconds_maps},
        {"translucency", L.seconds_translucency},
        {"hl2_error", L.seconds_hl2_error}}},
      {"warnings", L.warnings},
  };
  return r.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace

StatusOr<LeafJobResult> RunLeafJob(const LeafJobOptions& o, const LeafProgress& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  auto step = [&](const char* stage, int64_t d, int64_t t) {
    return !progress || progress(stage, d, t);
  };
  std::error_code ec;
  MATFIT_RETURN_IF_ERROR(CheckOutput(o.out, o.overwrite));
  if (!step("read", 0, 1)) return Status(StatusCode::kCancelled, "cancelled");
  LeafScanReadOptions ro;
  ro.manifest = o.manifest;
  ro.confine = o.confine;
  ro.max_samples = o.max_stack_samples;
  ro.crop = o.crop;
  auto scan = ReadLeafScan(o.input, ro);
  if (!scan.ok()) return scan.status();
  if (o.max_thickness_mm > 0) scan->max_thickness_mm = o.max_thickness_mm;
  if (!step("read", 1, 1)) return Status(StatusCode::kCancelled, "cancelled");
  // The top-lit stack moves into the analysis, not copied.
  auto sheet =
      AnalyzeSheet(&*scan, o.sheet, [&](int64_t d, int64_t t) { return step("sheet", d, t); });
  if (!sheet.ok()) return sheet.status();
  LeafJobResult res;
  res.seconds_sheet = Since(t0);
  res.warnings = scan->warnings;
  for (const auto& w : sheet->warnings) res.warnings.push_back(w);
  const auto& comps = sheet->segmentation.components;
  std::vector<double> sides;
  for (const auto& c : comps) {
    res.leaves += c.kind == ComponentKind::kLeaf;
    res.twigs += c.kind == ComponentKind::kTwig;
    res.specks += c.kind == ComponentKind::kSpeck;
    if (c.kind == ComponentKind::kMarker) ++res.markers, sides.push_back(c.side_px);
  }
  if (res.leaves == 0)
    return DataError("no leaves found on '" + o.input + "' (found " + std::to_string(res.twigs) +
                     " twigs, " + std::to_string(res.markers) + " markers, " +
                     std::to_string(res.specks) +
                     " specks): a leaf is a coloured region transmitting under half the back "
                     "light; check the back-lit images");
  // Scale.
  const double marker_mm = o.marker_size_mm > 0 ? o.marker_size_mm : scan->marker_size_mm;
  if (o.mm_per_pixel > 0) {
    res.mm_per_pixel = o.mm_per_pixel, res.scale_source = "option";
  } else if (scan->mm_per_pixel > 0) {
    res.mm_per_pixel = scan->mm_per_pixel, res.scale_source = "manifest";
  } else if (marker_mm > 0 && !sides.empty()) {
    std::nth_element(sides.begin(), sides.begin() + sides.size() / 2, sides.end());
    res.mm_per_pixel = marker_mm / sides[sides.size() / 2], res.scale_source = "markers";
  } else {
    res.mm_per_pixel = o.default_mm_per_pixel, res.scale_source = "default";
    res.warnings.push_back(
        Warning(WarningCode::kNoScale,
                std::string("no physical scale: ") +
                    (marker_mm > 0 ? "no square markers were found"
                                   : "give mm_per_pixel or marker_size_mm") +
                    "; assumed " + std::to_string(o.default_mm_per_pixel) +
                    " mm per pixel for the translucency kernel, areas in mm² are not reported"));
  }
  const bool scale_known = res.scale_source != "default";
  if (o.only_leaf > res.leaves)
    return InvalidArgument("--leaf " + std::to_string(o.only_leaf) + ": the sheet has leaves 1.." +
                           std::to_string(res.leaves));

  // Distributed: leaf k (in sheet order) belongs to rank k mod N; rank 0 owns the folder, which
  // every rank writes its leaves' packs into.
  const Comm* comm = o.comm && o.comm->size() > 1 ? o.comm : nullptr;
  const int rank = comm ? comm->rank() : 0, ranks = comm ? comm->size() : 1;
  AtomicDir dir(o.out, "leaf-pack");
  const Status begun = rank == 0 ? dir.Begin(o.overwrite) : Status::Ok();
  fs::path root = dir.temp_path();
  if (comm) {
    std::string failed;
    if (!AllOk(*comm, begun.ok(), begun.ok() ? "" : begun.message(), &failed))
      return begun.ok() ? Status(StatusCode::kIoError, failed) : begun;
    root = comm->AllGather(rank == 0 ? dir.temp_path() : "")[0];
  }
  MATFIT_RETURN_IF_ERROR(begun);
  const auto t_leaves = std::chrono::steady_clock::now();
  json others = json::array();
  // One record per leaf this rank fits: its leaves.json entry, its summary and its leaf-flagged
  // warning; merged in sheet order below (on rank 0, from every rank).
  json records = json::array();
  std::vector<const Component*> mine;
  int leaf_index = 0;
  for (const auto& c : comps) {
    if (c.kind != ComponentKind::kLeaf) {
      if (c.kind != ComponentKind::kSpeck)
        others.push_back({{"kind", ComponentKindName(c.kind)},
                          {"bbox", Bbox(c)},
                          {"area_px", c.area_px},
                          {"touches_border", c.touches_border}});
      continue;
    }
    if (o.only_leaf && c.id != o.only_leaf) continue;
    if (leaf_index++ % ranks == rank) mine.push_back(&c);
  }
  int done = 0;
  // Per leaf: the material's steps, then its pack (maps, previews) written.
  const int64_t per_leaf = kLeafMaterialSteps + 1, leaf_steps = per_leaf * int64_t(mine.size());
  auto fit_leaves = [&]() -> Status {
    for (const Component* leaf : mine) {
      const Component& c = *leaf;
      auto L = MakeLeafMaterial(
          *scan, *sheet, c, res.mm_per_pixel, o.material,
          [&](int64_t d, int64_t) { return step("leaves", done * per_leaf + d, leaf_steps); });
      if (!L.ok())
        return Status(L.status().code(),
                      "leaf " + std::to_string(c.id) + ": " + L.status().message());
      char name[32];
      std::snprintf(name, sizeof name, "leaf_%02d", c.id);
      int64_t flagged = 0, inside = 0;
      for (uint8_t s : L->status)
        flagged += s != fit::kTexelOk && s != fit::kTexelMasked, inside += s != fit::kTexelMasked;
      const double flagged_fraction = double(flagged) / double(std::max<int64_t>(1, inside));
      json warning;
      if (flagged_fraction > kLeafFlaggedWarnFraction)
        warning = Warning(
            WarningCode::kLeafFlagged,
            std::string(name) + " has " + std::to_string(int(std::lround(100 * flagged_fraction))) +
                " % of its texels " + "flagged (" + std::to_string(flagged) + " of " +
                std::to_string(inside) +
                "): its maps there are the best estimate, not a fit; see its status map");
      if (c.touches_border)
        L->warnings.push_back(Warning(WarningCode::kLeafAtBorder,
                                      "the leaf touches the image border: it is probably cut off"));
      PackInfo info;
      info.method = "leaf";
      info.source = o.source_label.empty() ? o.input : o.source_label;
      info.mm_per_texel = scale_known ? res.mm_per_pixel : 0;
      info.report_json = LeafReport(*L, o.material, flagged);
      info.warnings = L->warnings;
      info.model_parameters["leaf_id"] = c.id;
      info.extra_maps.push_back({"thickness_variation", "thickness_variation.png",
                                 "2005: inverted transmission luminance", L->thickness_variation});
      info.extra_maps.push_back(
          {"absorption", "absorption.png", "2005: absorption modulation A(x)", L->absorption});
      info.extra_maps.push_back(
          {"bump", "bump.png", "2005: high-passed upper-side luminance (bump)", L->bump});
      if (o.preview) {
        for (bool behind : {false, true}) {
          auto img = o.preview(L->maps, behind);
          if (!img.ok()) return img.status();
          info.previews.push_back(
              {behind ? "preview_back.png" : "preview_front.png", std::move(*img)});
        }
      }
      MATFIT_RETURN_IF_ERROR(WritePack(L->maps, L->status, info, {}, (root / name).string()));
      const double hl2 = (L->hl2_error[0].mean + L->hl2_error[1].mean + L->hl2_error[2].mean) / 3;
      const double a_mm2 = c.area_px * res.mm_per_pixel * res.mm_per_pixel;
      records.push_back({{"entry",
                          {{"id", c.id},
                           {"name", name},
                           {"pack", name},
                           {"bbox", Bbox(c)},
                           {"centroid", {c.cx, c.cy}},  // where segmentation.png numbers it
                           {"crop", {L->crop_x, L->crop_y, L->maps.width, L->maps.height}},
                           {"area_px", c.area_px},
                           {"area_mm2", scale_known ? json(a_mm2) : json()},
                           {"touches_border", c.touches_border},
                           {"thickness_estimated", L->thickness_estimated},
                           {"flagged_texels", flagged},
                           {"flagged_fraction", flagged_fraction},
                           {"hl2_error_percent", 100 * hl2}}},
                         {"summary",
                          {{"area_px", c.area_px},
                           {"flagged", flagged},
                           {"fraction", flagged_fraction},
                           {"hl2", hl2}}},
                         {"warning", warning}});
      ++done;
      if (!step("leaves", done * per_leaf, leaf_steps))
        return Status(StatusCode::kCancelled, "cancelled");
    }
    return Status::Ok();
  };
  const Status fitted = fit_leaves();
  if (comm) {
    // Every rank's leaves, to rank 0; the others wait for its outcome.
    std::string failed;
    if (!AllOk(*comm, fitted.ok(), fitted.ok() ? "" : fitted.message(), &failed))
      return fitted.ok() ? Status(StatusCode::kDataError, failed) : fitted;
    const std::vector<std::string> all = comm->Gather(records.dump(), 0);
    if (rank != 0) {
      if (!AllOk(*comm, true, "", &failed))
        return Status(StatusCode::kIoError, "rank 0: " + failed);
      res.seconds_leaves = Since(t_leaves), res.seconds_total = Since(t0);
      return res;
    }
    records = json::array();
    for (const std::string& r : all)
      for (auto& record : json::parse(r)) records.push_back(std::move(record));
  }
  MATFIT_RETURN_IF_ERROR(fitted);
  // Sheet order (the ids increase along it), as one process fits them.
  std::stable_sort(records.begin(), records.end(), [](const json& a, const json& b) {
    return a["entry"]["id"].get<int>() < b["entry"]["id"].get<int>();
  });
  json leaves = json::array();
  for (const json& r : records) {
    leaves.push_back(r["entry"]);
    LeafSummary sm;
    sm.id = r["entry"]["id"], sm.name = r["entry"]["name"];
    sm.area_px = r["summary"]["area_px"], sm.flagged_texels = r["summary"]["flagged"];
    sm.flagged_fraction = r["summary"]["fraction"];
    // JSON has no NaN (a leaf without texels): it travels as null.
    sm.mean_hl2_error = r["summary"]["hl2"].is_number() ? r["summary"]["hl2"].get<double>() : NAN;
    res.summary.push_back(sm);
    if (!r["warning"].is_null()) res.warnings.push_back(r["warning"]);
  }
  res.seconds_leaves = Since(t_leaves);
  // Rank 0 (or the only process) writes the sheet's files and leaves.json and commits.
  auto write = [&]() -> Status {
    if (!step("write", 0, 1)) return Status(StatusCode::kCancelled, "cancelled");
    MATFIT_RETURN_IF_ERROR(WriteImage((root / "segmentation.png").string(),
                                      SegmentationOverlay(*sheet),
                                      {PixelFormat::kUint8, TransferFunction::kLinear}));
    MATFIT_RETURN_IF_ERROR(WriteImage((root / "transmission.exr").string(), sheet->transmission,
                                      {PixelFormat::kHalf, TransferFunction::kLinear}));
    res.seconds_total = Since(t0);
    json index = {
        {"schema", "matfit.leaves/1"},
        {"source", o.source_label.empty() ? o.input : o.source_label},
        {"size", {{"width", sheet->width}, {"height", sheet->height}}},
        {"crop", o.crop ? json({{"x", o.crop->x},
                                {"y", o.crop->y},
                                {"width", o.crop->w},
                                {"height", o.crop->h}})
                        : json()},
        {"scale", {{"mm_per_pixel", res.mm_per_pixel}, {"source", res.scale_source}}},
        {"counts",
         {{"leaves", res.leaves},
          {"twigs", res.twigs},
          {"markers", res.markers},
          {"specks", res.specks}}},
        {"leaves", leaves},
        {"others", others},
        {"segmentation", "segmentation.png"},
        {"transmission", "transmission.exr"},
        {"background_fit_rms_log",
         {{"back_lit", sheet->back_rms_log}, {"top_lit", sheet->top_rms_log}}},
        {"timings_seconds",
         {{"sheet", res.seconds_sheet},
          {"leaves", res.seconds_leaves},
          {"total", res.seconds_total}}},
        {"warnings", res.warnings},
        {"version", std::string("matfit ") + kMatfitVersion},
    };
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic(
        (root / "leaves.json").string(),
        index.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n"));
    return dir.Commit();
  };
  const Status written = write();
  if (comm) {
    std::string failed;
    AllOk(*comm, written.ok(), written.ok() ? "" : written.message(), &failed);
  }
  MATFIT_RETURN_IF_ERROR(written);
  step("write", 1, 1);
  return res;
}

}  // namespace matfit::leaf
