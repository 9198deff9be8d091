// The whole `matfit leaf` path: read the scan → analyse the sheet (flat field, fused
// transmission, segmentation) → one leaf material per leaf → a pack per leaf + leaves.json,
// written atomically as one output folder. The CLI and the server share it.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/image.h"
#include "core/material_maps.h"
#include "core/status.h"
#include "leaf/leaf_material.h"
#include "leaf/sheet.h"

namespace matfit {
class Comm;
}

namespace matfit::leaf {

struct LeafJobOptions {
  std::string input;     // leaf-scan folder
  std::string manifest;  // optional manifest path (else DIR/leaf.json or detection)
  std::string out;       // output folder
  bool overwrite = false;
  SheetOptions sheet;
  LeafMaterialOptions material;
  // Overrides of the manifest (0 = keep).
  double mm_per_pixel = 0, marker_size_mm = 0, max_thickness_mm = 0;
  double default_mm_per_pixel = 0.5;  // used, with a warning, when no scale is known
  int only_leaf = 0;                  // process just this leaf id (0 = every leaf)
  bool confine = false;               // every file the scan names must lie inside `input`
  int64_t max_stack_samples = 0;      // images × w × h × channels of the scan; 0 = no limit
  std::optional<CropRect> crop;       // --crop: only this region of every image of the scan
  // Preview renders of a leaf pack lit from the front / from behind (render/); empty = none.
  std::function<StatusOr<Image>(const MaterialMaps&, bool from_behind)> preview;
  // What leaves.json and the packs name as the input (empty: `input`). The server passes a
  // name that does not reveal its own folders.
  std::string source_label;
  // The ranks of a distributed run (mpirun/srun; docs/scale-out.md); null or one rank: this
  // process does everything. Every rank reads the scan and analyses the sheet (the segmentation
  // needs all of it); leaf k (in sheet order) is fitted and written by rank k mod N, and rank 0
  // writes leaves.json and commits the folder, which equals a single process's.
  const Comm* comm = nullptr;
  bool Check(std::string* why) const;
};

// A leaf with more flagged texels than this gets a leaf-flagged warning and a summary line.
inline constexpr double kLeafFlaggedWarnFraction = 0.2;

struct LeafSummary {
  int id = 0;
  std::string name;  // "leaf_01"
  int64_t area_px = 0;
  double mean_hl2_error = 0;  // mean over the three elevations, fraction
  int64_t flagged_texels = 0;
  double flagged_fraction = 0;  // of the leaf's texels
};

struct LeafJobResult {
  int leaves = 0, twigs = 0, markers = 0, specks = 0;
  double mm_per_pixel = 0;
  std::string scale_source;  // "option", "manifest", "markers", "default"
  std::vector<LeafSummary> summary;
  double seconds_total = 0, seconds_sheet = 0, seconds_leaves = 0;
  std::vector<std::string> warnings;
};

// stage: "read", "sheet", "leaves", "write"; return false to cancel.
using LeafProgress = std::function<bool(const std::string& stage, int64_t done, int64_t total)>;
StatusOr<LeafJobResult> RunLeafJob(const LeafJobOptions& options,
                                   const LeafProgress& progress = {});

}  // namespace matfit::leaf
