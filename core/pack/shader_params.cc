#include "core/pack/shader_params.h"

#include <algorithm>
#include <string>

namespace matfit {

namespace {

// Appends the first `count` planes of `img`; false (naming the map) when it is absent or the
// wrong size.
bool AddPlanes(const Image& img, int count, int w, int h, std::vector<const float*>* planes,
               std::string* missing, const char* name) {
  if (img.width() != w || img.height() != h || img.channels() < count) {
    *missing = name;
    return false;
  }
  for (int c = 0; c < count; ++c) planes->push_back(img.Plane(c).data());
  return true;
}

// Fills g's metadata and the plane list in layout order; `ones` / `zeros` stand in for absent
// optional maps (they may be null when the planes are only checked, never read).
Status CollectPlanes(const MaterialMaps& m, const float* ones, const float* zeros,
                     ShaderParams* out, std::vector<const float*>* out_planes) {
  ShaderParams& g = *out;
  std::vector<const float*>& planes = *out_planes;
  g.width = m.width, g.height = m.height;
  g.model = int(m.model);
  const int w = m.width, h = m.height;
  if (w <= 0 || h <= 0) return InvalidArgument("material has no texels");
  std::string missing;
  bool ok = true;
  if (m.normal.empty()) {  // mean/ptm/hsh packs may omit it: flat
    planes.insert(planes.end(), {zeros, zeros, ones});
  } else {
    ok = ok && AddPlanes(m.normal, 3, w, h, &planes, &missing, "normal");
  }
  ok = ok && AddPlanes(m.albedo, 3, w, h, &planes, &missing, "albedo");
  if (ok && m.mask.empty())
    planes.push_back(ones);
  else
    ok = ok && AddPlanes(m.mask, 1, w, h, &planes, &missing, "mask");
  switch (m.model) {
    case ShadingModel::kBlinnPhong:
      ok = ok && AddPlanes(m.specular, 1, w, h, &planes, &missing, "specular");
      ok = ok && AddPlanes(m.exponent, 1, w, h, &planes, &missing, "exponent");
      break;
    case ShadingModel::kCookTorrance:
      ok = ok && AddPlanes(m.specular, 1, w, h, &planes, &missing, "specular (F0)");
      ok = ok && AddPlanes(m.roughness, 1, w, h, &planes, &missing, "roughness");
      break;
    case ShadingModel::kLafortune:
      g.terms = m.specular.channels();
      ok = ok && g.terms >= 1 && g.terms <= 4;
      ok = ok && AddPlanes(m.specular, g.terms, w, h, &planes, &missing, "specular (ρ_s)");
      ok = ok && AddPlanes(m.lobe_shape, 2 * g.terms, w, h, &planes, &missing, "lobe_shape");
      break;
    case ShadingModel::kHeinrich:
      ok = ok && AddPlanes(m.ambient, 3, w, h, &planes, &missing, "ambient");
      if (ok && m.normal_scale.empty())
        planes.push_back(ones);
      else
        ok = ok && AddPlanes(m.normal_scale, 1, w, h, &planes, &missing, "normal_scale");
      g.heinrich_specular = !m.specular_color.empty();
      g.flat_normal = m.specular_flat_normal;
      if (ok && g.heinrich_specular) {
        ok = ok && AddPlanes(m.specular_color, 3, w, h, &planes, &missing, "specular_color");
        ok = ok && AddPlanes(m.exponent, 1, w, h, &planes, &missing, "exponent");
      }
      break;
    case ShadingModel::kPtm:
    case ShadingModel::kHsh:
      g.terms = m.basis_terms;
      g.coef_channels = g.terms > 0 ? m.coefficients.channels() / g.terms : 0;
      ok = ok && g.terms >= 1 && g.terms <= 16 && (g.coef_channels == 1 || g.coef_channels == 3);
      ok = ok && AddPlanes(m.coefficients, g.terms * g.coef_channels, w, h, &planes, &missing,
                           "coefficients");
      break;
    default: break;
  }
  if (ok && !m.translucency.empty()) {
    g.leaf_base = int(planes.size());
    ok = ok && AddPlanes(m.translucency, 3, w, h, &planes, &missing, "translucency");
    ok = ok && AddPlanes(m.albedo_back.empty() ? m.albedo : m.albedo_back, 3, w, h, &planes,
                         &missing, "albedo_back");
    g.leaf_hl2 = !m.hl2.empty();
    if (g.leaf_hl2) ok = ok && AddPlanes(m.hl2, 3, w, h, &planes, &missing, "hl2");
  }
  if (!ok)
    return InvalidArgument(std::string("material (") + ShadingModelName(m.model) + "): map '" +
                           (missing.empty() ? "lobe/basis terms" : missing) +
                           "' is missing or not " + std::to_string(w) + " × " + std::to_string(h));
  g.layers = int((planes.size() + 3) / 4);
  return Status::Ok();
}

}  // namespace

Status CheckShaderMaps(const MaterialMaps& m) {
  ShaderParams g;
  std::vector<const float*> planes;
  return CollectPlanes(m, nullptr, nullptr, &g, &planes);
}

StatusOr<ShaderParams> PackShaderParams(const MaterialMaps& m) {
  ShaderParams g;
  std::vector<const float*> planes;
  const size_t n_texels = size_t(std::max(0, m.width)) * size_t(std::max(0, m.height));
  const std::vector<float> ones(n_texels, 1.0f), zeros(n_texels, 0.0f);
  if (Status st = CollectPlanes(m, ones.data(), zeros.data(), &g, &planes); !st.ok()) return st;
  const int w = m.width, h = m.height;
  g.texels.assign(size_t(g.layers) * w * h * 4, 0.0f);
  const int64_t n = int64_t(w) * h;
  for (size_t q = 0; q < planes.size(); ++q) {
    float* dst = g.texels.data() + (q / 4) * n * 4 + q % 4;
    for (int64_t p = 0; p < n; ++p) dst[p * 4] = planes[q][p];
  }
  return g;
}

}  // namespace matfit
