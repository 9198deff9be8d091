// Reads a material pack folder back into MaterialMaps (for `matfit fit --report-only` and
// round-trip tests). Exact float maps are preferred where the pack has them.
#pragma once

#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/status.h"

namespace matfit {

struct PackViewContents;

struct PackContents {
  MaterialMaps maps;
  std::vector<uint8_t> status;  // from maps/status.png (0 = ok)
  std::string method;
  // A per-view pack (material.json "views"): every view's maps, each read from its own pack
  // under views/ (maps above: the most frontal view's). Empty for any other pack.
  std::vector<PackViewContents> views;
};

struct PackViewContents {
  double theta_deg = 0, phi_deg = 0;
  MaterialMaps maps;
  std::vector<uint8_t> status;
};

// The view of a per-view pack nearest the direction (θ, φ) in degrees (largest cosine): an
// index into views, or −1 when the pack has none.
int NearestPackView(const PackContents& pack, double theta_deg, double phi_deg);

StatusOr<PackContents> ReadPack(const std::string& dir);

}  // namespace matfit
