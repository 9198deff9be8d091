#include "leaf/hl2_error.h"

#include <cmath>
#include <numbers>

#include "leaf/hl2.h"

namespace matfit::leaf {

StatusOr<Hl2ErrorStats> Hl2ReconstructionError(const TransportInput& in,
                                               const TranslucencyOptions& o,
                                               const TranslucencyResult& r, double elev) {
  if (!(elev > 0 && elev <= std::numbers::pi / 2 + 1e-12))
    return InvalidArgument("light elevation must be in (0, π/2] radians");
  Hl2ErrorStats st;
  double sum = 0;
  const bool overhead = elev > std::numbers::pi / 2 - 1e-9;
  for (double az : {0.3, 1.9, 3.5, 5.1}) {
    const Vec3 w(std::cos(elev) * std::cos(az), std::cos(elev) * std::sin(az), std::sin(elev));
    auto L = DirectionalTranslucency(in, o, w);
    if (!L.ok()) return L.status();
    for (int64_t i = 0; i < L->plane_size(); ++i) {
      const double ref = L->Plane(0)[i];
      if ((in.mask && !(*in.mask)[i]) || !(ref > 0.05 * r.response.Plane(0)[i] * w.z)) continue;
      const std::array<double, 3> h = {r.hl2_raw.Plane(0)[i], r.hl2_raw.Plane(1)[i],
                                       r.hl2_raw.Plane(2)[i]};
      const double e = std::abs(Hl2Reconstruct(h, w) - ref) / ref;
      sum += e, ++st.texels;
      const double edges[5] = {0.01, 0.02, 0.05, 0.10, 0.20};
      int b = 0;
      while (b < 5 && e >= edges[b]) ++b;
      ++st.histogram[b];
    }
    if (overhead) break;
  }
  st.mean = st.texels ? sum / st.texels : 0;
  return st;
}

}  // namespace matfit::leaf
