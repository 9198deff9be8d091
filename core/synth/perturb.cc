#include "core/synth/perturb.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "core/parallel.h"
#include "core/synth/random.h"

namespace matfit::synth {

bool PerturbOptions::Check(std::string* why) const {
  if (!(gaussian_sigma >= 0 && gaussian_sigma <= 1)) {
    *why =
        "--noise must be in [0, 1] (fraction of full scale), got " + std::to_string(gaussian_sigma);
    return false;
  }
  if (!(shot_photons == 0 || shot_photons >= 1)) {
    *why = "--shot-noise must be 0 (off) or ≥ 1 photons at full scale, got " +
           std::to_string(shot_photons);
    return false;
  }
  if (!(clip == 0 || (clip > 0 && clip <= 1))) {
    *why = "--clip must be in (0, 1] (or 0 for none), got " + std::to_string(clip);
    return false;
  }
  if (!(misregister_px >= 0 && misregister_px <= 16)) {
    *why = "--misregister must be in [0, 16] pixels, got " + std::to_string(misregister_px);
    return false;
  }
  return true;
}

PerturbRecord ApplyPerturbations(const PerturbOptions& o, LightStack* stack) {
  const int n = stack->num_images(), w = stack->width(), h = stack->height();
  const int64_t texels = stack->plane_size();
  PerturbRecord rec;
  rec.shift_x.assign(n, 0.0);
  rec.shift_y.assign(n, 0.0);
  std::atomic<int64_t> clipped{0};
  ParallelFor(0, n, [&](int64_t b, int64_t e) {
    std::vector<float> src;
    for (int64_t i = b; i < e; ++i) {
      if (o.misregister_px > 0) {
        const double sx = o.misregister_px * (2 * HashUniform(o.seed, 0x5417, i, 0) - 1);
        const double sy = o.misregister_px * (2 * HashUniform(o.seed, 0x5417, i, 1) - 1);
        rec.shift_x[i] = sx, rec.shift_y[i] = sy;
        for (int c = 0; c < stack->channels(); ++c) {
          auto plane = stack->Plane(int(i), c);
          src.assign(plane.begin(), plane.end());
          // out(x, y) = in(x − sx, y − sy), bilinear, edge clamp.
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
              const double px = std::clamp(x - sx, 0.0, double(w - 1));
              const double py = std::clamp(y - sy, 0.0, double(h - 1));
              const int x0 = std::min(int(px), std::max(0, w - 2)),
                        y0 = std::min(int(py), std::max(0, h - 2));
              const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
              const double fx = px - x0, fy = py - y0;
              plane[int64_t(y) * w + x] =
                  float((src[y0 * w + x0] * (1 - fx) + src[y0 * w + x1] * fx) * (1 - fy) +
                        (src[y1 * w + x0] * (1 - fx) + src[y1 * w + x1] * fx) * fy);
            }
        }
      }
      int64_t local_clipped = 0;
      for (int c = 0; c < stack->channels(); ++c) {
        float* p = stack->Plane(int(i), c).data();
        for (int64_t t = 0; t < texels; ++t) {
          double v = p[t];
          const uint64_t key = uint64_t(t) * 4 + c;
          if (o.shot_photons > 0 && v > 0)
            v += std::sqrt(v / o.shot_photons) * HashGaussian(o.seed, 0x5407, i, key);
          if (o.gaussian_sigma > 0) v += o.gaussian_sigma * HashGaussian(o.seed, 0x6a55, i, key);
          if (o.clip > 0 && v > o.clip) v = o.clip, ++local_clipped;
          p[t] = float(v);
        }
      }
      clipped += local_clipped;
    }
  });
  rec.clipped_samples = clipped.load();
  return rec;
}

}  // namespace matfit::synth
