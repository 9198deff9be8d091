#include "core/material_maps.h"

#include <algorithm>

#include "core/model/model.h"

namespace matfit {

const char* ShadingModelName(ShadingModel m) { return Model(m).name(); }

namespace {

// A texel-sized plane cut to the region; planes of any other size (not texel planes, or a
// malformed truth map) are dropped rather than read out of bounds.
Image CropPlanes(const Image& img, int full_w, int full_h, int x, int y, int w, int h) {
  if (img.empty() || img.width() != full_w || img.height() != full_h) return {};
  Image out(w, h, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int r = 0; r < h; ++r)
      std::copy_n(img.Plane(c).data() + int64_t(y + r) * img.width() + x, w,
                  out.Plane(c).data() + int64_t(r) * w);
  return out;
}

// Every texel-sized plane of MaterialMaps.
constexpr Image MaterialMaps::*kTexelPlanes[] = {
    &MaterialMaps::normal,       &MaterialMaps::albedo,
    &MaterialMaps::height_map,   &MaterialMaps::specular,
    &MaterialMaps::exponent,     &MaterialMaps::roughness,
    &MaterialMaps::thickness,    &MaterialMaps::translucency,
    &MaterialMaps::albedo_back,  &MaterialMaps::hl2,
    &MaterialMaps::mask,         &MaterialMaps::ambient,
    &MaterialMaps::normal_scale, &MaterialMaps::specular_color,
    &MaterialMaps::coefficients, &MaterialMaps::interpolation_error,
    &MaterialMaps::lobe_shape};

}  // namespace

MaterialMaps CropMaps(const MaterialMaps& m, int x, int y, int w, int h) {
  MATFIT_CHECK(x >= 0 && y >= 0 && w > 0 && h > 0 && x + w <= m.width && y + h <= m.height);
  MaterialMaps out = m;
  out.width = w, out.height = h;
  for (Image MaterialMaps::*plane : kTexelPlanes)
    out.*plane = CropPlanes(m.*plane, m.width, m.height, x, y, w, h);
  return out;
}

void PasteMaps(const MaterialMaps& tile, int x, int y, MaterialMaps* into) {
  MATFIT_CHECK(x >= 0 && y >= 0 && x + tile.width <= into->width &&
               y + tile.height <= into->height);
  for (Image MaterialMaps::*plane : kTexelPlanes) {
    const Image& src = tile.*plane;
    if (src.empty() || src.width() != tile.width || src.height() != tile.height) continue;
    Image& dst = into->*plane;
    if (dst.empty() || dst.width() != into->width || dst.height() != into->height)
      dst = Image(into->width, into->height, src.channels());
    MATFIT_CHECK(dst.channels() == src.channels(), "PasteMaps: plane channel counts differ");
    for (int c = 0; c < src.channels(); ++c)
      for (int r = 0; r < tile.height; ++r)
        std::copy_n(src.Plane(c).data() + int64_t(r) * tile.width, tile.width,
                    dst.Plane(c).data() + int64_t(y + r) * into->width + x);
  }
}

}  // namespace matfit
