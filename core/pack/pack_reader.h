// Reads a material pack folder back into MaterialMaps (for `matfit fit --report-only` and
// round-trip tests). Exact float maps are preferred where the pack has them.
#pragma once

#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

struct PackContents {
  MaterialMaps maps;
  std::vector<uint8_t> status;  // from maps/status.png (0 = ok)
  std::string method;
};

StatusOr<PackContents> ReadPack(const std::string& dir);

}  // namespace matfit
