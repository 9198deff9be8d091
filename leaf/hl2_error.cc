#include "leaf/hl2_error.h"

#include <cmath>
#include <numbers>

#include "leaf/hl2.h"

namespace matfit::leaf {

StatusOr<std::vector<Hl2ErrorStats>> Hl2ReconstructionErrors(const TransportInput& in,
                                                             const TranslucencyOptions& o,
                                                             const TranslucencyResult& r,
                                                             const std::vector<double>& elevations,
                                                             int64_t max_texels) {
  // Lights: four azimuths per elevation, one when overhead.
  std::vector<Vec3> lights;
  std::vector<int> owner;
  for (size_t k = 0; k < elevations.size(); ++k) {
    const double el = elevations[k];
    if (!(el > 0 && el <= std::numbers::pi / 2 + 1e-12))
      return InvalidArgument("light elevation must be in (0, π/2] radians, got " +
                             std::to_string(el));
    const bool overhead = el > std::numbers::pi / 2 - 1e-9;
    for (double az : {0.3, 1.9, 3.5, 5.1}) {
      lights.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      owner.push_back(int(k));
      if (overhead) break;
    }
  }
  // The leaf texels, evenly subsampled.
  std::vector<int64_t> texels;
  const int64_t n = r.response.plane_size();
  for (int64_t i = 0; i < n; ++i)
    if (!in.mask || (*in.mask)[i]) texels.push_back(i);
  if (max_texels > 0 && int64_t(texels.size()) > max_texels) {
    std::vector<int64_t> sub;
    const double step = double(texels.size()) / max_texels;
    for (int64_t j = 0; j < max_texels; ++j) sub.push_back(texels[int64_t(j * step)]);
    texels.swap(sub);
  }
  auto L = DirectionalTranslucency(in, o, lights, &texels);
  if (!L.ok()) return L.status();
  std::vector<Hl2ErrorStats> st(elevations.size());
  std::vector<double> sum(elevations.size(), 0.0);
  for (size_t m = 0; m < lights.size(); ++m) {
    Hl2ErrorStats& s = st[owner[m]];
    const Vec3& w = lights[m];
    for (int64_t i : texels) {
      const double ref = (*L)[m].Plane(0)[i];
      if (!(ref > 0.05 * r.response.Plane(0)[i] * w.z)) continue;
      const std::array<double, 3> h = {r.hl2_raw.Plane(0)[i], r.hl2_raw.Plane(1)[i],
                                       r.hl2_raw.Plane(2)[i]};
      const double e = std::abs(Hl2Reconstruct(h, w) - ref) / ref;
      sum[owner[m]] += e, ++s.texels;
      const double edges[5] = {0.01, 0.02, 0.05, 0.10, 0.20};
      int b = 0;
      while (b < 5 && e >= edges[b]) ++b;
      ++s.histogram[b];
    }
  }
  for (size_t k = 0; k < st.size(); ++k) st[k].mean = st[k].texels ? sum[k] / st[k].texels : 0;
  return st;
}

StatusOr<Hl2ErrorStats> Hl2ReconstructionError(const TransportInput& in,
                                               const TranslucencyOptions& o,
                                               const TranslucencyResult& r, double elev) {
  auto v = Hl2ReconstructionErrors(in, o, r, {elev}, 0);
  if (!v.ok()) return v.status();
  return (*v)[0];
}

}  // namespace matfit::leaf
