// Reads the truth/ folder that `matfit synth` writes beside a dataset (for scoring fits).
#pragma once

#include <string>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit::synth {

// The truth folder of a dataset at `source` (a folder, or a .lp file inside one), or empty.
std::string FindTruthFolder(const std::string& source);

// Reads normal.exr, albedo.exr and mask.png (required) plus any optional maps present. With
// `confine_to` (the server's dataset folder) every file must resolve inside it.
StatusOr<MaterialMaps> ReadTruth(const std::string& truth_dir, const std::string& confine_to = "");

// Whether the truth maps' model renders the dataset's images (params.json "appearance" is not
// "micro-geometry"): only then is relighting the maps a truth to compare relighting errors with.
bool TruthMapsAreTheAppearance(const std::string& truth_dir, const std::string& confine_to = "");

}  // namespace matfit::synth
