#include "capture/calibrate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace matfit::capture {

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
  // Kåsa: x² + y² + D x + E y + F = 0 in least squares.
  const int n = int(xs.size());
  Eigen::MatrixXd m(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    m(i, 0) = xs[size_t(i)], m(i, 1) = ys[size_t(i)], m(i, 2) = 1;
    b(i) = -(xs[size_t(i)] * xs[size_t(i)] + ys[size_t(i)] * ys[size_t(i)]);
  }
  const Eigen::Vector3d s = m.colPivHouseholderQr().solve(b);
  SphereFit f;
  f.cx = -s(0) / 2, f.cy = -s(1) / 2;
  const double r2 = f.cx * f.cx + f.cy * f.cy - s(2);
  if (!(r2 > 0)) return DataError("the sphere mask is not round enough to fit a circle");
  // Boundary pixel centres lie half a pixel inside the silhouette edge.
  f.radius = std::sqrt(r2) + 0.5;
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
  float peak = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (std::hypot(x - s.cx, y - s.cy) < r_in) peak = std::max(peak, value(int64_t(y) * w + x));
  if (!(peak > 0)) return DataError("no highlight on the sphere (the image is black inside it)");
  const double thr = (1 - o.highlight_fraction) * peak;
  double sx = 0, sy = 0, sw = 0;
  int count = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (std::hypot(x - s.cx, y - s.cy) >= r_in) continue;
      const float v = value(int64_t(y) * w + x);
      if (v < thr) continue;
      const double wt = v - thr + 1e-6;
      sx += wt * x, sy += wt * y, sw += wt, ++count;
    }
  if (!(o.highlight_fraction > 0 && o.highlight_fraction < 1))
    return InvalidArgument("highlight fraction must be in (0, 1)");
  if (!(sw > 0)) return DataError("no highlight pixels on the sphere");
  LightEstimate e;
  e.hx = sx / sw, e.hy = sy / sw, e.peak = peak, e.pixels = count;
  const double nx = (e.hx - s.cx) / s.radius, ny = -(e.hy - s.cy) / s.radius;
  const double nz = std::sqrt(std::max(0.0, 1 - nx * nx - ny * ny));
  const Vec3 n{nx, ny, nz};
  Vec3 v{0, 0, 1};
  if (o.perspective) {
    if (!(o.focal_px > 0)) return InvalidArgument("perspective calibration needs --focal-px > 0");
    const double px = (w - 1) / 2.0, py = (h - 1) / 2.0;
    const double vx = -(e.hx - px), vy = (e.hy - py), vz = o.focal_px;  // toward the camera
    const double len = std::sqrt(vx * vx + vy * vy + vz * vz);
    v = {vx / len, vy / len, vz / len};
  }
  const double nv = n.x * v.x + n.y * v.y + n.z * v.z;
  Vec3 l{2 * nv * n.x - v.x, 2 * nv * n.y - v.y, 2 * nv * n.z - v.z};
  const double len = std::sqrt(l.x * l.x + l.y * l.y + l.z * l.z);
  e.direction = {l.x / len, l.y / len, l.z / len};
  return e;
}

double AngleDeg(const Vec3& a, const Vec3& b) {
  const double d = std::clamp(a.x * b.x + a.y * b.y + a.z * b.z, -1.0, 1.0);
  return std::acos(d) * 180.0 / M_PI;
}

}  // namespace matfit::capture
