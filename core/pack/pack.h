// Material packs: maps + material.json + material.gltf (+ quad.bin) + report.json + preview,
// as a folder or a zip. Layout and schema: docs/pack.md.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/material_maps.h"
#include "core/progress_fn.h"
#include "core/status.h"

namespace matfit {

// A map beyond the model's own (e.g. a leaf's derived maps), written under maps/.
struct PackExtraMap {
  std::string name, file, semantic;  // file: e.g. "bump.png" (8-bit) or "absorption.exr"
  Image image;
};

// A file beyond the maps at a path of its own (e.g. pca/v000_weights.exr): an image (written as
// float EXR) or text; listed in material.json "extras" with its role.
struct PackExtraFile {
  std::string path;  // relative to the pack, no ".."
  std::string role;
  Image image;       // written when not empty
  std::string text;  // else this
};

// One view of a per-view pack (per-view:<model>, docs/pack.md "Per-view packs"): its maps are
// written as a pack of their own under views/.
struct PackView {
  double theta_deg = 0, phi_deg = 0;
  const MaterialMaps* maps = nullptr;
  const std::vector<uint8_t>* status = nullptr;
  const std::map<std::string, double>* parameters = nullptr;  // the view's (null: the pack's)
};

struct PackInfo {
  std::string method;                              // fitting method name
  std::string source;                              // dataset path
  std::string report_json;                         // contents of report.json (already serialised)
  std::map<std::string, double> model_parameters;  // e.g. exponent
  double mm_per_texel = 0;                         // 0 = unknown
  std::vector<std::string> warnings;
  std::vector<PackExtraMap> extra_maps;
  // Extra preview renders at the pack root (file name → linear image, written as sRGB PNG).
  std::vector<std::pair<std::string, Image>> previews;
  // When set, called after every other file of the pack is written; its result is written as
  // report.json instead of report_json (so the report can time the write itself).
  std::function<std::string()> final_report_json;
  // A per-view fit: every view's maps (the pack's own maps are the most frontal view's), each
  // written as a complete pack views/vNNN/ and listed in material.json "views".
  std::vector<PackView> views;
  std::vector<PackExtraFile> extra_files;
};

struct PackWriteOptions {
  bool zip = false;        // write one .zip file instead of a folder
  bool overwrite = false;  // replace an existing output
  bool compact = false;    // smaller, slower-to-write map files (ImageWriteOptions::compact)
  // Optional: the write's progress in thousandths (the glTF bake of a relighting basis, the
  // files, the view packs), called one at a time; the return value is ignored.
  ProgressFn progress;
};

// Writes the pack atomically to `out` (a folder; with zip, `out` is the .zip file path).
Status WritePack(const MaterialMaps& maps, const std::vector<uint8_t>& status, const PackInfo& info,
                 const PackWriteOptions& options, const std::string& out);

// Zips every file under `folder` (paths relative to it) into `zip_path` (not atomic: pass a
// temporary name).
Status ZipFolder(const std::string& folder, const std::string& zip_path);

// Physically based stand-ins for the glTF core material: GGX roughness from a Blinn–Phong
// exponent, r = (2/(e+2))^{1/4} (α = sqrt(2/(e+2)), r = sqrt(α)).
double RoughnessFromBlinnPhongExponent(double e);

}  // namespace matfit
