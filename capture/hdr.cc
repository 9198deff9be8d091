#include "capture/hdr.h"

#include <algorithm>

#include "core/check.h"

namespace matfit::capture {

Image MergeBrackets(const std::vector<Bracket>& b, const HdrOptions& o, int64_t* saturated) {
  MATFIT_CHECK(!b.empty());
  const Image& first = *b[0].frame;
  const int w = first.width(), h = first.height(), ch = first.channels();
  const int64_t n = int64_t(w) * h;
  size_t shortest = 0, longest = 0;
  for (size_t i = 0; i < b.size(); ++i) {
    MATFIT_CHECK(b[i].frame->width() == w && b[i].frame->height() == h &&
                 b[i].frame->channels() == ch);
    if (b[i].exposure_s < b[shortest].exposure_s) shortest = i;
    if (b[i].exposure_s > b[longest].exposure_s) longest = i;
  }
  Image out(w, h, ch);
  int64_t sat = 0;
  for (int64_t p = 0; p < n; ++p) {
    bool any_channel_clipped = false;
    for (int c = 0; c < ch; ++c) {
      bool clipped_everywhere = true;
      double num = 0, den = 0;
      for (const Bracket& k : b) {
        const float f = k.frame->Plane(c)[p];
        const float d = k.dark ? k.dark->Plane(c)[p] : 0.0f;
        const double hat = std::min(f - o.low, o.high - f);
        if (f < o.high) clipped_everywhere = false;
        if (hat <= 0) continue;
        const double wgt = k.exposure_s * hat;
        num += wgt * (f - d) / k.exposure_s;
        den += wgt;
      }
      any_channel_clipped = any_channel_clipped || clipped_everywhere;
      if (den > 0) {
        out.Plane(c)[p] = float(num / den);
      } else {
        const Bracket& k = b[b[shortest].frame->Plane(c)[p] >= o.high ? shortest : longest];
        const float d = k.dark ? k.dark->Plane(c)[p] : 0.0f;
        out.Plane(c)[p] = float((k.frame->Plane(c)[p] - d) / k.exposure_s);
      }
    }
    sat += any_channel_clipped;
  }
  if (saturated) *saturated = sat;
  return out;
}

Image NormaliseFlat(const Image& flat) {
  Image out = flat;
  for (int c = 0; c < out.channels(); ++c) {
    double sum = 0;
    for (float v : out.Plane(c)) sum += v;
    const double mean = sum / double(out.plane_size());
    for (float& v : out.Plane(c)) v = mean > 0 ? float(v / mean) : 1.0f;
  }
  return out;
}

void ApplyFlatField(const Image& flat, Image* img) {
  MATFIT_CHECK(flat.width() == img->width() && flat.height() == img->height());
  for (int c = 0; c < img->channels(); ++c) {
    const auto f = flat.Plane(std::min(c, flat.channels() - 1));
    auto p = img->Plane(c);
    for (int64_t i = 0; i < img->plane_size(); ++i) p[i] = f[i] > 1e-6f ? p[i] / f[i] : 0.0f;
  }
}

}  // namespace matfit::capture
