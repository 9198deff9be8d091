#include "capture/calibrate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace matfit::capture {

bool FitCircle(const std::vector<double>& xs, const std::vector<double>& ys, double* cx, double* cy,
               double* r) {
  // Kåsa: x² + y² + D x + E y + F = 0 in least squares.
  const int n = int(std::min(xs.size(), ys.size()));
  if (n < 3) return false;
  Eigen::MatrixXd m(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    m(i, 0) = xs[size_t(i)], m(i, 1) = ys[size_t(i)], m(i, 2) = 1;
    b(i) = -(xs[size_t(i)] * xs[size_t(i)] + ys[size_t(i)] * ys[size_t(i)]);
  }
  const Eigen::Vector3d s = m.colPivHouseholderQr().solve(b);
  *cx = -s(0) / 2, *cy = -s(1) / 2;
  const double r2 = *cx * *cx + *cy * *cy - s(2);
  if (!(r2 > 0)) return false;
  *r = std::sqrt(r2);
  return true;
}

StatusOr<SphereFit> FitSphere(const Image& mask) {
  const int w = mask.width(), h = mask.height();
  auto in = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h && mask.Plane(0)[int64_t(y) * w + x] > 0.5f;
  };
  // Boundary pixels: inside with an outside 4-neighbour.
  Eigen::MatrixXd a;
  std::vector<double> xs, ys;
  int64_t area = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!in(x, y)) continue;
      ++area;
      if (!in(x - 1, y) || !in(x + 1, y) || !in(x, y - 1) || !in(x, y + 1))
        xs.push_back(x), ys.push_back(y);
    }
  if (area < 50 || xs.size() < 20)
    return DataError("the sphere mask has " + std::to_string(area) +
                     " pixels; it must show the whole sphere (white = sphere)");
  const int n = int(xs.size());
  SphereFit f;
  double r0 = 0;
  if (!FitCircle(xs, ys, &f.cx, &f.cy, &r0))
    return DataError("the sphere mask is not round enough to fit a circle");
  // Boundary pixel centres lie half a pixel inside the silhouette edge.
  f.radius = r0 + 0.5;
  double sse = 0;
  for (int i = 0; i < n; ++i)
    sse += std::pow(std::hypot(xs[size_t(i)] - f.cx, ys[size_t(i)] - f.cy) + 0.5 - f.radius, 2);
  f.rms_px = std::sqrt(sse / n);
  if (f.rms_px > 0.05 * f.radius)
    return DataError("the sphere mask is not a disc (boundary rms " + std::to_string(f.rms_px) +
                     " px for radius " + std::to_string(f.radius) + " px)");
  return f;
}

StatusOr<LightEstimate> EstimateLight(const Image& img, const SphereFit& s,
                                      const SphereCalibrationOptions& o) {
  const int w = img.width(), h = img.height();
  auto value = [&](int64_t i) {
    float v = 0;
    for (int c = 0; c < img.channels(); ++c) v = std::max(v, img.Plane(c)[i]);
    return v;
  };
  const double r_in = 0.98 * s.radius;  // stay off the limb
  auto inside = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h && std::hypot(x - s.cx, y - s.cy) < r_in;
  };
  float peak = 0;
  int64_t at = -1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (inside(x, y) && value(int64_t(y) * w + x) > peak)
        peak = value(int64_t(y) * w + x), at = int64_t(y) * w + x;
  if (!(peak > 0)) return DataError("no highlight on the sphere (the image is black inside it)");
  if (!(o.highlight_fraction > 0 && o.highlight_fraction < 1))
    return InvalidArgument("highlight fraction must be in (0, 1)");
  if (o.perspective && !(o.focal_px > 0))
    return InvalidArgument("perspective calibration needs --focal-px > 0");
  const double thr = (1 - o.highlight_fraction) * peak;
  // The view direction at pixel (x, y): toward the camera (orthographic: +z).
  auto view = [&](double x, double y) {
    if (!o.perspective) return Vec3{0, 0, 1};
    const double px = (w - 1) / 2.0, py = (h - 1) / 2.0;
    return Normalize(Vec3{-(x - px), (y - py), o.focal_px});
  };
  // The highlight: the 8-connected region of pixels ≥ thr grown from the peak (other bright
  // reflections in the sphere, a window or a second lamp, are not part of it).
  std::vector<uint8_t> in_spot(size_t(w) * h, 0);
  std::vector<int64_t> stack{at};
  in_spot[size_t(at)] = 1;
  while (!stack.empty()) {
    const int64_t i = stack.back();
    stack.pop_back();
    const int x = int(i % w), y = int(i / w);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if (!inside(xx, yy)) continue;
        const int64_t j = int64_t(yy) * w + xx;
        if (!in_spot[size_t(j)] && value(j) >= thr) in_spot[size_t(j)] = 1, stack.push_back(j);
      }
  }
  // Every highlight pixel's mirror direction R = 2(n·v)n − v, averaged with weight v − thr.
  // Orthographic, a pixel covers the same solid angle of R wherever it is on the sphere
  // (dω_R = 4 dA / r²), so a highlight symmetric about the light averages to it exactly; an
  // image-space centroid is pulled toward the sphere's centre by the foreshortening.
  double sx = 0, sy = 0, sw = 0;
  Vec3 sum{0, 0, 0};
  int count = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!in_spot[size_t(y) * w + x]) continue;
      const float v = value(int64_t(y) * w + x);
      const double wt = v - thr + 1e-6;
      const double nx = (x - s.cx) / s.radius, ny = -(y - s.cy) / s.radius;
      const Vec3 n{nx, ny, std::sqrt(std::max(0.0, 1 - nx * nx - ny * ny))};
      const Vec3 vv = view(x, y);
      const double nv = n.x * vv.x + n.y * vv.y + n.z * vv.z;
      sum = {sum.x + wt * (2 * nv * n.x - vv.x), sum.y + wt * (2 * nv * n.y - vv.y),
             sum.z + wt * (2 * nv * n.z - vv.z)};
      sx += wt * x, sy += wt * y, sw += wt, ++count;
    }
  if (!(sw > 0)) return DataError("no highlight pixels on the sphere");
  LightEstimate e;
  e.hx = sx / sw, e.hy = sy / sw, e.peak = peak, e.pixels = count;
  e.direction = Normalize(sum);
  return e;
}

double AngleDeg(const Vec3& a, const Vec3& b) {
  const double d = std::clamp(a.x * b.x + a.y * b.y + a.z * b.z, -1.0, 1.0);
  return std::acos(d) * 180.0 / M_PI;
}

}  // namespace matfit::capture
