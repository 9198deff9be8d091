#include "leaf/synthetic_leaf.h"

#include "core/check.h"
#include "core/synth/materials.h"
#include "leaf/horizon.h"

namespace matfit::leaf {

void MakeSyntheticLeaf(int size, double mm, double relief, SyntheticLeaf* s) {
  auto m = synth::MakeMaterial("leaf", size, 7);
  MATFIT_CHECK(m.ok());
  const int64_t n = int64_t(size) * size;
  s->rho = Image(size, size, 1), s->thickness = m->thickness;
  s->height_mm = Image(size, size, 1);
  s->mask.assign(n, 0);
  const auto& t = m->translucency;
  Image height_tex(size, size, 1);
  for (int64_t i = 0; i < n; ++i) {
    // Transmission weight: luminance of ρ_t (Rec. 709).
    s->rho.Plane(0)[i] =
        0.2126f * t.Plane(0)[i] + 0.7152f * t.Plane(1)[i] + 0.0722f * t.Plane(2)[i];
    s->mask[i] = m->mask.Plane(0)[i] > 0.5f;
    height_tex.Plane(0)[i] = float(relief * m->height_map.Plane(0)[i]);
    s->height_mm.Plane(0)[i] = float(height_tex.Plane(0)[i] * mm);  // texel units → mm
  }
  s->normal = synth::NormalsFromHeight(height_tex);
  s->horizon = HorizonMap(s->height_mm, mm, -1, HorizonOptions{});
  s->input = TransportInput{};
  s->input.mm_per_texel = mm;
  s->input.rho = &s->rho, s->input.thickness = &s->thickness, s->input.normal = &s->normal;
  s->input.horizon = &s->horizon, s->input.mask = &s->mask;
}

}  // namespace matfit::leaf
