// Random, valid parameter maps for every registered model (tests of the descriptors and of
// the batched evaluation). Deterministic in the seed.
#pragma once

#include <cmath>
#include <random>

#include "core/material_maps.h"
#include "core/model/model.h"

namespace matfit::testing {

// `grey`: ptm/hsh/rbf coefficients for one channel only (grey stacks).
inline MaterialMaps RandomModelMaps(ShadingModel id, int w, int h, uint32_t seed,
                                    bool grey = false) {
  std::mt19937 rng(seed);
  auto u = [&](double a, double b) {
    return float(std::uniform_real_distribution<double>(a, b)(rng));
  };
  auto fill = [&](Image* img, int channels, double a, double b) {
    *img = Image(w, h, channels);
    for (float& v : img->data()) v = u(a, b);
  };
  MaterialMaps m;
  m.width = w, m.height = h, m.model = id;
  m.normal = Image(w, h, 3);
  for (int64_t p = 0; p < int64_t(w) * h; ++p) {
    const double theta = u(0, 1.2), phi = u(-M_PI, M_PI);
    m.normal.Plane(0)[p] = float(std::sin(theta) * std::cos(phi));
    m.normal.Plane(1)[p] = float(std::sin(theta) * std::sin(phi));
    m.normal.Plane(2)[p] = float(std::cos(theta));
  }
  fill(&m.albedo, 3, 0.05, 0.9);
  m.mask = Image(w, h, 1, 1.0f);
  const std::string name = Model(id).name();
  if (name == "blinn-phong") {
    fill(&m.specular, 1, 0.0, 1.0), fill(&m.exponent, 1, 3, 120);
  } else if (name == "cook-torrance") {
    fill(&m.specular, 1, 0.02, 0.3), fill(&m.roughness, 1, 0.08, 0.9);
  } else if (name == "lafortune") {
    fill(&m.specular, 2, 0.0, 0.8);
    m.lobe_shape = Image(w, h, 4);
    for (int64_t p = 0; p < int64_t(w) * h; ++p) {
      m.lobe_shape.Plane(0)[p] = u(-1.3, -0.6), m.lobe_shape.Plane(1)[p] = u(2, 60);
      m.lobe_shape.Plane(2)[p] = u(-0.2, 0.4), m.lobe_shape.Plane(3)[p] = u(1, 10);
    }
  } else if (name == "heinrich") {
    fill(&m.ambient, 3, -0.2, 0.4), fill(&m.normal_scale, 1, 0.5, 1.5);
    fill(&m.specular_color, 3, -0.05, 0.5);
    m.exponent = Image(w, h, 1, u(5, 60));
    m.specular_flat_normal = (seed & 1) != 0;
  } else if (name == "ptm" || name == "hsh") {
    m.basis_terms = name == "ptm" ? 6 : (seed & 1 ? 9 : 4);
    fill(&m.coefficients, (grey ? 1 : 3) * m.basis_terms, -0.5, 0.7);
  } else if (name == "rbf") {
    // A random smooth-ish table: k terms on a 9 × 9 grid (any size ≥ 2 is valid).
    m.basis_terms = seed & 1 ? 9 : 5;
    fill(&m.coefficients, (grey ? 1 : 3) * m.basis_terms, -0.5, 0.7);
    m.basis_table = Image(9, 9, m.basis_terms);
    for (float& v : m.basis_table.data()) v = u(-0.4, 1.0);
  }
  return m;
}

}  // namespace matfit::testing
