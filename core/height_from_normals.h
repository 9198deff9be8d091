// Height map from a normal map: the least-squares surface whose slopes are the normals' (a
// Poisson solve; docs/pack.md "Height map"). Compute only, no I/O.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"

namespace matfit {

struct HeightOptions {
  // Conjugate-gradient iterations (each preconditioned by a multigrid V-cycle) and their stop:
  // the residual's norm relative to the right-hand side's.
  int max_iterations = 150;
  double tolerance = 1e-6;
  // Weight of the slope-0 (membrane) links to and between texels without a trusted normal,
  // relative to a trusted link (1): they fill holes smoothly and tie separate regions together
  // without pulling on the fitted slopes.
  double fill_weight = 1e-3;
  // |slope| cap (height per texel): normals closer to the surface plane than atan(1/cap) would
  // give unbounded slopes.
  double max_slope = 10;
  bool Check(std::string* why) const;
};

struct HeightResult {
  Image height;             // 1 plane, height in texel units (x right, y up), mean 0 over trusted
  double min = 0, max = 0;  // over trusted texels
  int iterations = 0;       // conjugate-gradient iterations
  double residual = 0;      // relative residual reached
};

// Integrates `normal` (3 planes, unit, x right, y up, z out of the surface) into heights.
// trusted[p] != 0 marks texels whose normal is used (size width × height; empty = all). The
// slope between two trusted neighbours is the mean of their normals' slopes: −n_x/n_z along x,
// −n_y/n_z along y (up); the solve minimises Σ w (z_b − z_a − slope)² over neighbour pairs
// (multigrid-preconditioned conjugate gradients; the same answer on any thread count).
HeightResult IntegrateNormals(const Image& normal, const std::vector<uint8_t>& trusted,
                              const HeightOptions& options = {});

}  // namespace matfit
