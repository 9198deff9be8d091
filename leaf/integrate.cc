#include "leaf/integrate.h"

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>

namespace matfit::leaf {

Image HeightFromNormals(const Image& n, const std::vector<uint8_t>& mask) {
  const int w = n.width(), h = n.height();
  // Mirror-pad to 2w × 2h so the periodic solution has no seams at the borders.
  const int W = 2 * w, H = 2 * h;
  cv::Mat p(H, W, CV_64F), q(H, W, CV_64F);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int sx = x < w ? x : W - 1 - x, sy = y < h ? y : H - 1 - y;
      const int64_t i = int64_t(sy) * w + sx;
      double gx = 0, gy = 0;
      if (mask.empty() || mask[i]) {
        const double nz = std::max(0.05, double(n.Plane(2)[i]));
        gx = -n.Plane(0)[i] / nz;  // ∂z/∂x, x = column
        gy = n.Plane(1)[i] / nz;   // ∂z/∂row (rows grow downward, y up)
      }
      // Mirroring flips the sign of the derivative across the mirrored axis.
      p.at<double>(y, x) = x < w ? gx : -gx;
      q.at<double>(y, x) = y < h ? gy : -gy;
    }
  cv::Mat P, Q;
  cv::dft(p, P, cv::DFT_COMPLEX_OUTPUT);
  cv::dft(q, Q, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat Z(H, W, CV_64FC2);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double wu = 2 * std::numbers::pi * (u <= W / 2 ? u : u - W) / W;
      const double wv = 2 * std::numbers::pi * (v <= H / 2 ? v : v - H) / H;
      const double d = wu * wu + wv * wv;
      const cv::Vec2d a = P.at<cv::Vec2d>(v, u), b = Q.at<cv::Vec2d>(v, u);
      // Z = (−i wu P − i wv Q) / (wu² + wv²)
      Z.at<cv::Vec2d>(v, u) =
          d > 0 ? cv::Vec2d((wu * a[1] + wv * b[1]) / d, -(wu * a[0] + wv * b[0]) / d)
                : cv::Vec2d(0, 0);
    }
  cv::Mat z;
  cv::dft(Z, z, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  Image out(w, h, 1);
  double mean = 0;
  int64_t cnt = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (mask.empty() || mask[int64_t(y) * w + x]) mean += z.at<double>(y, x), ++cnt;
  mean = cnt ? mean / cnt : 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.At(0, y, x) = float(z.at<double>(y, x) - mean);
  return out;
}

}  // namespace matfit::leaf
