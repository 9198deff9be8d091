// The files of a pack that other tools open (docs/pack.md "Exports"): PTM for ptm fits, HSH .rti
// for hsh fits, and the relight / OpenLIME web layout (relight/) for both.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

// Writes the exports the fit allows into the pack folder `root` (atomic per file) and appends
// one entry per export to *exports (material.json's "exports": file, format, values).
Status WritePackExports(const MaterialMaps& maps, const std::string& root, nlohmann::json* exports);

}  // namespace matfit
