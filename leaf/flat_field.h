// Smooth background of an image from the pixels known to be background (the sheet): the
// near-light brightness fall-off of top-lit images and the unobstructed back light of back-lit
// ones. log I(u, v) ≈ Σ_{a+b≤degree} c_ab u^a v^b with u, v ∈ [−1, 1] the pixel position,
// least squares over a pixel grid, with two rounds of trimming (|residual| > 2.5σ: shadows
// cast on the sheet, dust, stray leaf edges).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/image.h"
#include "core/status.h"

namespace matfit::leaf {

struct BackgroundOptions {
  int degree = 4;             // polynomial degree in (u, v), 0..6
  int stride = 0;             // sample every stride-th pixel in x and y; 0 = about 40 000 samples
  double saturation = 0.995;  // samples at or above this are clipped: not used
  bool Check(std::string* why) const;
};

struct BackgroundFit {
  Image level;          // 1 plane: fitted background brightness (linear)
  double rms_log = 0;   // RMS residual of log I over the kept samples
  int64_t samples = 0;  // samples kept after trimming
};

// `plane` is w×h; `background[i]` = 1 where pixel i shows the bare sheet. Fails when fewer than
// 50 background samples with positive brightness remain.
StatusOr<BackgroundFit> FitBackground(std::span<const float> plane, int w, int h,
                                      const std::vector<uint8_t>& background,
                                      const BackgroundOptions& options);

}  // namespace matfit::leaf
