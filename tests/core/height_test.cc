// Height from normals (core/height_from_normals.h): analytic surfaces whose normals are exact
// are integrated back within 2 % of their relief, with a mask, holes and separate regions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "core/height_from_normals.h"
#include "core/parallel.h"

namespace matfit {
namespace {

struct Surface {
  std::function<double(double, double)> z;   // height at (x, y_up), texel units
  std::function<double(double, double)> zx;  // ∂z/∂x
  std::function<double(double, double)> zy;  // ∂z/∂y_up
};

// Normal map of `s` on a W × H grid: texel (col, row) sits at x = col, y_up = H − 1 − row.
Image NormalsOf(const Surface& s, int W, int H) {
  Image n(W, H, 3);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const double x = c, y = H - 1 - r;
      const double a = -s.zx(x, y), b = -s.zy(x, y), len = std::sqrt(a * a + b * b + 1);
      n.At(0, r, c) = float(a / len), n.At(1, r, c) = float(b / len),
                 n.At(2, r, c) = float(1 / len);
    }
  return n;
}

// Largest |recovered − truth| over trusted texels after removing the mean difference, and the
// truth's relief (max − min) there.
void Compare(const Surface& s, const HeightResult& h, const std::vector<uint8_t>& trusted, int W,
             int H, double* worst, double* relief, double* rms) {
  double mean = 0, lo = 1e300, hi = -1e300;
  int64_t k = 0;
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const size_t p = size_t(r) * W + c;
      if (!trusted.empty() && !trusted[p]) continue;
      const double t = s.z(c, H - 1 - r);
      mean += h.height.Plane(0)[p] - t, ++k;
      lo = std::min(lo, t), hi = std::max(hi, t);
    }
  mean /= double(k);
  *worst = 0, *rms = 0;
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const size_t p = size_t(r) * W + c;
      if (!trusted.empty() && !trusted[p]) continue;
      const double e = h.height.Plane(0)[p] - s.z(c, H - 1 - r) - mean;
      *worst = std::max(*worst, std::abs(e)), *rms += e * e;
    }
  *rms = std::sqrt(*rms / double(k));
  *relief = hi - lo;
}

Surface Dome(double cx, double cy, double amp, double sigma) {
  auto g = [=](double x, double y) {
    return amp * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * sigma * sigma));
  };
  return {g, [=](double x, double y) { return -g(x, y) * (x - cx) / (sigma * sigma); },
          [=](double x, double y) { return -g(x, y) * (y - cy) / (sigma * sigma); }};
}

TEST(HeightFromNormals, ADomeOnATiltedPlaneComesBackWithin2PercentOfItsRelief) {
  const int W = 120, H = 90;
  const Surface dome = Dome(50, 40, 12, 14);
  // Dome + tilt (0.05 per texel along x, −0.03 along y) + ripples.
  Surface s{[&](double x, double y) {
              return dome.z(x, y) + 0.05 * x - 0.03 * y +
                     1.5 * std::sin(x / 7.0) * std::cos(y / 9.0);
            },
            [&](double x, double y) {
              return dome.zx(x, y) + 0.05 + 1.5 / 7.0 * std::cos(x / 7.0) * std::cos(y / 9.0);
            },
            [&](double x, double y) {
              return dome.zy(x, y) - 0.03 - 1.5 / 9.0 * std::sin(x / 7.0) * std::sin(y / 9.0);
            }};
  const HeightResult h = IntegrateNormals(NormalsOf(s, W, H), {});
  ASSERT_EQ(h.height.width(), W);
  double worst, relief, rms;
  Compare(s, h, {}, W, H, &worst, &relief, &rms);
  EXPECT_GT(relief, 15);
  EXPECT_LT(worst, 0.02 * relief) << "relief " << relief << " rms " << rms;
  EXPECT_NEAR(h.max - h.min, relief, 0.02 * relief);
  EXPECT_LT(h.residual, 1e-3);
}

TEST(HeightFromNormals, MaskHolesAndSeparateRegionsKeepTheirShape) {
  const int W = 96, H = 64;
  const Surface s = Dome(30, 30, 8, 9);
  std::vector<uint8_t> trusted(size_t(W) * H, 0);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const double x = c, y = H - 1 - r;
      const bool disc = (x - 30) * (x - 30) + (y - 30) * (y - 30) < 26 * 26;
      const bool hole = std::abs(x - 24) < 3 && std::abs(y - 34) < 3;  // flagged texels
      trusted[size_t(r) * W + c] = disc && !hole;
    }
  Image n = NormalsOf(s, W, H);
  // Untrusted texels carry garbage that must not leak into the result.
  for (size_t p = 0; p < trusted.size(); ++p)
    if (!trusted[p]) n.Plane(0)[p] = 0.9f, n.Plane(1)[p] = -0.4f, n.Plane(2)[p] = 0.1f;
  const HeightResult h = IntegrateNormals(n, trusted);
  double worst, relief, rms;
  Compare(s, h, trusted, W, H, &worst, &relief, &rms);
  EXPECT_LT(worst, 0.02 * relief) << "relief " << relief << " rms " << rms;
  // Heights are finite everywhere (holes filled, the outside flat-ish), mean 0 over trusted.
  double mean = 0;
  int64_t k = 0;
  for (size_t p = 0; p < trusted.size(); ++p) {
    ASSERT_TRUE(std::isfinite(h.height.Plane(0)[p]));
    if (trusted[p]) mean += h.height.Plane(0)[p], ++k;
  }
  EXPECT_NEAR(mean / double(k), 0, 1e-6);
}

TEST(HeightFromNormals, AFlatMapIsFlatAndGrazingNormalsStayBounded) {
  Image flat(40, 30, 3, 0.f);
  for (size_t p = 0; p < size_t(40 * 30); ++p) flat.Plane(2)[p] = 1;
  const HeightResult h = IntegrateNormals(flat, {});
  EXPECT_NEAR(h.max - h.min, 0, 1e-9);
  Image grazing = flat;
  grazing.Plane(0)[5] = 1, grazing.Plane(2)[5] = 1e-7f;  // slope capped, not infinite
  const HeightResult g = IntegrateNormals(grazing, {});
  EXPECT_TRUE(std::isfinite(g.max - g.min));
  EXPECT_LT(g.max - g.min, 20);
  // Strips and single texels (levels of one row or column, no coarser level at all).
  for (auto [w, rows] : {std::pair{1, 1}, {1, 9}, {9, 1}, {3, 3}, {5, 2}, {17, 1}}) {
    Image tilt(w, rows, 3, 0.f);
    for (size_t p = 0; p < size_t(w * rows); ++p) tilt.Plane(0)[p] = -0.6f, tilt.Plane(2)[p] = 0.8f;
    const HeightResult t = IntegrateNormals(tilt, {});
    EXPECT_NEAR(t.max - t.min, 0.75 * (w - 1), 1e-4) << w << " x " << rows;  // slope 0.6 / 0.8
  }
}

// The multigrid-preconditioned solve converges to its tolerance in a few iterations on a large,
// rough map with a mask, a hole and garbage outside (the Jacobi-preconditioned one it replaced
// stopped at 150 iterations 70× short of it), and its answer does not depend on the threads.
TEST(HeightFromNormals, ConvergesInFewIterationsAndIsTheSameOnAnyThreadCount) {
  const int W = 300, H = 210;
  const Surface dome = Dome(150, 100, 30, 40);
  Surface s{
      [&](double x, double y) { return dome.z(x, y) + 2 * std::sin(x / 3.0) * std::cos(y / 4.0); },
      [&](double x, double y) {
        return dome.zx(x, y) + 2 / 3.0 * std::cos(x / 3.0) * std::cos(y / 4.0);
      },
      [&](double x, double y) {
        return dome.zy(x, y) - 2 / 4.0 * std::sin(x / 3.0) * std::sin(y / 4.0);
      }};
  std::vector<uint8_t> trusted(size_t(W) * H, 0);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const double u = (c - 150) / 140.0, v = (r - 105) / 95.0;
      const bool hole = std::abs(c - 100) < 12 && std::abs(r - 80) < 9;
      trusted[size_t(r) * W + c] = u * u + v * v < 1 && !hole;
    }
  Image n = NormalsOf(s, W, H);
  for (size_t p = 0; p < trusted.size(); ++p)
    if (!trusted[p]) n.Plane(0)[p] = -0.7f, n.Plane(1)[p] = 0.5f, n.Plane(2)[p] = 0.5f;
  SetNumThreads(1);
  const HeightResult one = IntegrateNormals(n, trusted);
  SetNumThreads(2);
  const HeightResult two = IntegrateNormals(n, trusted);
  SetNumThreads(0);
  EXPECT_LE(one.iterations, 30);
  EXPECT_LE(one.residual, HeightOptions{}.tolerance);
  double worst, relief, rms;
  Compare(s, one, trusted, W, H, &worst, &relief, &rms);
  EXPECT_LT(worst, 0.02 * relief) << "relief " << relief << " rms " << rms;
  ASSERT_EQ(two.iterations, one.iterations);
  for (size_t p = 0; p < trusted.size(); ++p)
    ASSERT_EQ(one.height.Plane(0)[p], two.height.Plane(0)[p]) << "texel " << p;
}

}  // namespace
}  // namespace matfit
