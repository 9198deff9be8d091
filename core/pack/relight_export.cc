#include "core/pack/relight_export.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/model/model.h"
#include "core/pack/rti_export.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"

namespace matfit {

void RelightPtmBasis(double lx, double ly, double* w) {
  w[0] = 1, w[1] = lx, w[2] = ly, w[3] = lx * lx, w[4] = lx * ly, w[5] = ly * ly;
}

namespace {

// The layout's term i = sign[i] × the fit's term from[i], checked by evaluating both bases.
Status PtmTermMap(int* from, double* sign) {
  constexpr int kFrom[6] = {5, 3, 4, 0, 2, 1};  // matfit: u², v², uv, u, v, 1
  const Vec3 l = Normalize(Vec3{0.31, 0.47, 0.83});
  double mine[shading::kPtmTerms], web[6];
  shading::PtmBasis(l, mine);
  RelightPtmBasis(l.x, l.y, web);
  for (int i = 0; i < 6; ++i) {
    from[i] = kFrom[i], sign[i] = 1;
    if (std::abs(mine[kFrom[i]] - web[i]) > 1e-12)
      return Status(StatusCode::kInternal,
                    "the relight PTM basis and matfit's differ in term " + std::to_string(i));
  }
  return Status::Ok();
}

}  // namespace

StatusOr<RelightWeb> EncodeRelightWeb(const MaterialMaps& m) {
  const int terms = m.basis_terms;
  const int ch = terms > 0 ? m.coefficients.channels() / terms : 0;
  const bool ptm = HasRtiBasis(m.model, "ptm") && terms == 6;
  const bool hsh = HasRtiBasis(m.model, "hsh") && (terms == 4 || terms == 9);
  if (!(ptm || hsh) || (ch != 1 && ch != 3) || m.coefficients.channels() != ch * terms ||
      m.coefficients.width() != m.width || m.coefficients.height() != m.height)
    return InvalidArgument(
        "the relight web layout holds a 6-term ptm or a 4- or 9-term hsh fit of 1 or 3 channels");
  int from[9];
  double sign[9];
  MATFIT_RETURN_IF_ERROR(ptm ? PtmTermMap(from, sign) : RtiHshTermMap(terms, from, sign));
  const int W = m.width, H = m.height, nplanes = 3 * terms;
  const int64_t n = int64_t(W) * H;
  auto plane_of = [&](int p) {  // the fit's plane for layout plane p = 3·term + channel
    return m.coefficients.Plane((ch == 3 ? p % 3 : 0) * terms + from[p / 3]);
  };
  // One image of 3 planes per term, each made and filled by one thread (the images in parallel).
  RelightWeb out;
  out.planes.resize(size_t(nplanes / 3));
  std::vector<double> scales(static_cast<size_t>(nplanes)), biases(scales);
  ParallelFor(0, nplanes / 3, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) {
      out.planes[size_t(i)] = Image(W, H, 3);
      for (int p = int(3 * i); p < 3 * i + 3; ++p) {
        const auto src = plane_of(p);
        const double s = sign[p / 3];
        double lo = 0, hi = 0;
        bool any = false;
        for (int64_t t = 0; t < n; ++t)
          if (std::isfinite(src[t])) {
            const double v = s * src[t];
            lo = any ? std::min(lo, v) : v, hi = any ? std::max(hi, v) : v, any = true;
          }
        // coefficient = (code / 255 − bias) × scale: code 0 is lo, code 255 is hi.
        const double sc = hi > lo ? hi - lo : 1.0, bi = -lo / sc;
        scales[size_t(p)] = sc, biases[size_t(p)] = bi;
        auto dst = out.planes[size_t(i)].Plane(p % 3);
        for (int64_t t = 0; t < n; ++t) {
          const double v = std::isfinite(src[t]) ? s * src[t] : 0.0;
          const long code = std::clamp(std::lround(255.0 * (v / sc + bi)), 0L, 255L);
          dst[t] = float(code) / 255.0f;
        }
      }
    }
  });
  nlohmann::json scale = nlohmann::json::array(), bias = nlohmann::json::array();
  for (int p = 0; p < nplanes; ++p)
    scale.push_back(scales[size_t(p)]), bias.push_back(biases[size_t(p)]);
  const nlohmann::json info = {
      {"width", W},
      {"height", H},
      {"format", "jpg"},
      {"type", ptm ? "ptm" : "hsh"},
      {"colorspace", "rgb"},
      {"nplanes", nplanes},
      {"quality", 100},
      {"materials", {{{"scale", scale}, {"bias", bias}}}},
      {"generator", "matfit"},
      {"values", m.basis_srgb ? "sRGB-encoded, as RTI tools fit them" : "linear radiance"},
  };
  out.info_json = info.dump(1, '\t') + "\n";
  return out;
}

}  // namespace matfit
