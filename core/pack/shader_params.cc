#include "core/pack/shader_params.h"

#include <algorithm>
#include <string>

#include "core/model/model.h"

namespace matfit {

namespace {

// Appends the first `count` planes of a map; remembers the first one absent or the wrong size.
class PlaneCollector final : public ShaderPlaneSink {
 public:
  PlaneCollector(int w, int h, const float* ones, std::vector<const float*>* planes)
      : w_(w), h_(h), ones_(ones), planes_(planes) {}
  bool Add(const Image& img, int count, const char* name) override {
    if (img.width() != w_ || img.height() != h_ || img.channels() < count) {
      if (missing.empty()) missing = name;
      return false;
    }
    for (int c = 0; c < count; ++c) planes_->push_back(img.Plane(c).data());
    return true;
  }
  void AddOnes() override { planes_->push_back(ones_); }
  void AddZeros(const float* zeros) { planes_->push_back(zeros); }
  std::string missing;

 private:
  int w_, h_;
  const float* ones_;
  std::vector<const float*>* planes_;
};

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
  PlaneCollector sink(w, h, ones, &planes);
  bool ok = true;
  if (m.normal.empty()) {  // mean/ptm/hsh packs may omit it: flat
    sink.AddZeros(zeros), sink.AddZeros(zeros), sink.AddOnes();
  } else {
    ok = ok && sink.Add(m.normal, 3, "normal");
  }
  ok = ok && sink.Add(m.albedo, 3, "albedo");
  if (ok && m.mask.empty())
    sink.AddOnes();
  else
    ok = ok && sink.Add(m.mask, 1, "mask");
  ok = ok && Model(m.model).AddShaderPlanes(m, &sink);
  g.terms = sink.terms, g.coef_channels = sink.coef_channels;
  g.heinrich_specular = sink.heinrich_specular, g.flat_normal = sink.flat_normal;
  g.basis_srgb = sink.basis_srgb;
  if (sink.basis_table) g.table_size = sink.basis_table->width();
  if (ok && !m.translucency.empty()) {
    g.leaf_base = int(planes.size());
    ok = ok && sink.Add(m.translucency, 3, "translucency");
    ok = ok && sink.Add(m.albedo_back.empty() ? m.albedo : m.albedo_back, 3, "albedo_back");
    g.leaf_hl2 = !m.hl2.empty();
    if (g.leaf_hl2) ok = ok && sink.Add(m.hl2, 3, "hl2");
  }
  if (!ok)
    return InvalidArgument(std::string("material (") + ShadingModelName(m.model) + "): map '" +
                           (sink.missing.empty() ? "lobe/basis terms" : sink.missing) +
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
  if (g.table_size > 0)
    g.basis_table.assign(m.basis_table.data().begin(), m.basis_table.data().end());
  const int w = m.width, h = m.height;
  const int64_t n = int64_t(w) * h;
  g.texels.resize(size_t(g.layers) * size_t(n) * 4);  // every element written below
  // Layer by layer, its four planes interleaved in one pass (lanes past the last plane: 0).
  for (int layer = 0; layer < g.layers; ++layer) {
    const float* lane[4];
    for (int k = 0; k < 4; ++k) {
      const size_t q = size_t(layer) * 4 + size_t(k);
      lane[k] = q < planes.size() ? planes[q] : zeros.data();
    }
    float* dst = g.texels.data() + size_t(layer) * size_t(n) * 4;
    for (int64_t p = 0; p < n; ++p)
      dst[4 * p] = lane[0][p], dst[4 * p + 1] = lane[1][p], dst[4 * p + 2] = lane[2][p],
              dst[4 * p + 3] = lane[3][p];
  }
  return g;
}

}  // namespace matfit
