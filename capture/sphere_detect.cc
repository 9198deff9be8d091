#include "capture/sphere_detect.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

namespace matfit::capture {
namespace {

float Luminance(const Image& img, int64_t i) {
  float v = 0;
  for (int c = 0; c < img.channels(); ++c) v = std::max(v, img.Plane(c)[i]);
  return v;
}

Image Downsample(const Image& lum, int f) {
  const int w = lum.width() / f, h = lum.height() / f;
  Image out(std::max(1, w), std::max(1, h), 1);
  for (int y = 0; y < out.height(); ++y)
    for (int x = 0; x < out.width(); ++x) {
      double s = 0;
      for (int dy = 0; dy < f; ++dy)
        for (int dx = 0; dx < f; ++dx)
          s += lum.At(0, std::min(lum.height() - 1, y * f + dy),
                      std::min(lum.width() - 1, x * f + dx));
      out.At(0, y, x) = float(s / (f * f));
    }
  return out;
}

double Percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, size_t(q * double(v.size())));
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

// The mean luminance as 8-bit: √(v / p90) clipped (highlights saturate, the dim background
// and the sphere's silhouette keep their contrast), blurred (σ `sigma` pixels).
cv::Mat Stretched(const Image& mean, double sigma) {
  const double top = std::max(1e-9, Percentile({mean.data().begin(), mean.data().end()}, 0.90));
  cv::Mat m(mean.height(), mean.width(), CV_8U);
  for (int y = 0; y < mean.height(); ++y)
    for (int x = 0; x < mean.width(); ++x)
      m.at<uint8_t>(y, x) = uint8_t(
          std::lround(255 * std::sqrt(std::clamp(double(mean.At(0, y, x)) / top, 0.0, 1.0))));
  cv::Mat b;
  cv::GaussianBlur(m, b, cv::Size(0, 0), sigma);
  return b;
}

double Bilinear(const cv::Mat& f, double x, double y) {
  if (x < 0 || y < 0 || x > f.cols - 1.001 || y > f.rows - 1.001) return NAN;
  const int x0 = int(x), y0 = int(y);
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int yy, int xx) { return double(f.at<float>(yy, xx)); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

struct Candidate {
  double x, y, r;        // full-resolution pixels
  double highlight = 0;  // fraction of photos with a compact highlight inside
};

}  // namespace

Status SphereEvidence::Add(const Image& photo) {
  const int w = photo.width(), h = photo.height();
  if (count == 0) {
    mean = Image(w, h, 1);
    factor = std::max(1, (std::max(w, h) + 639) / 640);
  } else if (w != mean.width() || h != mean.height()) {
    return InvalidArgument("the photos differ in size (" + std::to_string(w) + "x" +
                           std::to_string(h) + " after " + std::to_string(mean.width()) + "x" +
                           std::to_string(mean.height()) + ")");
  }
  ++count;
  Image lum(w, h, 1);
  for (int64_t i = 0; i < lum.plane_size(); ++i) {
    lum.Plane(0)[i] = Luminance(photo, i);
    mean.Plane(0)[i] += (lum.Plane(0)[i] - mean.Plane(0)[i]) / float(count);
  }
  small.push_back(Downsample(lum, factor));
  return Status::Ok();
}

bool SphereDetectOptions::Check(std::string* why) const {
  if (spheres < 1 || spheres > 16) return *why = "spheres must be in [1, 16]", false;
  if (!(min_radius_frac > 0 && min_radius_frac < max_radius_frac && max_radius_frac <= 0.5))
    return *why = "radius fractions must satisfy 0 < min < max <= 0.5", false;
  return true;
}

StatusOr<SphereFit> RefineSphere(const Image& mean, double cx, double cy, double r) {
  if (!(r >= 3)) return InvalidArgument("a sphere radius of at least 3 pixels is needed");
  // The edge is found on the stretched image (the silhouette of a dark sphere on a dark
  // background shows there) and placed where the blurred LINEAR profile crosses halfway between
  // its levels on either side: where an ideal step is, whatever the stretch (whose steepest
  // point lies toward the step's dark side).
  const double sigma = std::max(1.0, r / 60);
  cv::Mat f, lin(mean.height(), mean.width(), CV_32F), fl;
  Stretched(mean, sigma).convertTo(f, CV_32F);
  for (int y = 0; y < mean.height(); ++y)
    for (int x = 0; x < mean.width(); ++x) lin.at<float>(y, x) = mean.At(0, y, x);
  cv::GaussianBlur(lin, fl, cv::Size(0, 0), sigma);
  // Edge points: the strongest radial step between 0.75 r and 1.25 r along 360 rays, with the
  // sign most rays agree on (the sphere darker or brighter than its surround).
  constexpr int kRays = 360;
  std::vector<double> ex[2], ey[2];
  const double step = 0.25;
  const int reach = int(std::ceil(3 * sigma / step));  // samples to the levels either side
  for (int k = 0; k < kRays; ++k) {
    const double a = 2 * std::numbers::pi * k / kRays, c = std::cos(a), s = std::sin(a);
    std::vector<double> prof, plin;
    for (double t = 0.75 * r; t <= 1.25 * r; t += step) {
      prof.push_back(Bilinear(f, cx + t * c, cy + t * s));
      plin.push_back(Bilinear(fl, cx + t * c, cy + t * s));
    }
    double best[2] = {0, 0};
    int at[2] = {-1, -1};
    for (size_t i = 1; i + 1 < prof.size(); ++i) {
      const double d = prof[i + 1] - prof[i - 1];
      if (!std::isfinite(d)) continue;
      const int sign = d > 0 ? 0 : 1;  // 0: brighter outside (a dark sphere)
      if (std::abs(d) > best[sign]) best[sign] = std::abs(d), at[sign] = int(i);
    }
    for (int sign = 0; sign < 2; ++sign) {
      const int i = at[sign];
      if (best[sign] < 2 || i - reach < 0 || size_t(i + reach) >= plin.size()) continue;
      const double lo = plin[size_t(i - reach)], hi = plin[size_t(i + reach)];
      if (!std::isfinite(lo) || !std::isfinite(hi) || (hi > lo) != (sign == 0)) continue;
      const double half = (lo + hi) / 2;
      double t = -1;
      for (int j = i - reach; j < i + reach && t < 0; ++j) {
        const double p0 = plin[size_t(j)], p1 = plin[size_t(j + 1)];
        if ((p0 - half) * (p1 - half) <= 0 && p0 != p1)
          t = 0.75 * r + (j + (half - p0) / (p1 - p0)) * step;
      }
      if (t > 0) ex[sign].push_back(cx + t * c), ey[sign].push_back(cy + t * s);
    }
  }
  const int sign = ex[0].size() >= ex[1].size() ? 0 : 1;
  std::vector<double> xs = ex[sign], ys = ey[sign];
  if (xs.size() < kRays / 4)
    return DataError("no clear sphere edge near (" + std::to_string(int(cx)) + ", " +
                     std::to_string(int(cy)) + ") r " + std::to_string(int(r)) +
                     " (edge found on " + std::to_string(xs.size()) +
                     " of 360 rays; the sphere must stand out from its surround in the photos)");
  SphereFit fit;
  double x0 = cx, y0 = cy, r0 = r;
  for (int pass = 0; pass < 3; ++pass) {
    if (!FitCircle(xs, ys, &x0, &y0, &r0)) return DataError("the sphere edge is not a circle");
    std::vector<double> res(xs.size());
    for (size_t i = 0; i < xs.size(); ++i)
      res[i] = std::abs(std::hypot(xs[i] - x0, ys[i] - y0) - r0);
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
    const double mad = std::max(0.05, sorted[sorted.size() / 2]);
    std::vector<double> kx, ky;
    for (size_t i = 0; i < xs.size(); ++i)
      if (res[i] <= 2.5 * 1.4826 * mad) kx.push_back(xs[i]), ky.push_back(ys[i]);
    if (pass < 2 && kx.size() >= size_t(kRays / 4)) xs.swap(kx), ys.swap(ky);
  }
  double sse = 0;
  for (size_t i = 0; i < xs.size(); ++i)
    sse += std::pow(std::hypot(xs[i] - x0, ys[i] - y0) - r0, 2);
  // Pixel centres are at integer coordinates here, as in the photos (SphereFit's convention).
  fit.cx = x0, fit.cy = y0, fit.radius = r0, fit.rms_px = std::sqrt(sse / double(xs.size()));
  fit.edge_coverage = double(xs.size()) / kRays;
  if (std::abs(r0 - r) > 0.25 * r || std::hypot(x0 - cx, y0 - cy) > 0.25 * r)
    return DataError("the sphere edge near (" + std::to_string(int(cx)) + ", " +
                     std::to_string(int(cy)) + ") r " + std::to_string(int(r)) +
                     " is not where the sphere was expected (" + std::to_string(int(x0)) + ", " +
                     std::to_string(int(y0)) + ") r " + std::to_string(int(r0)) +
                     "); give X,Y,R within a quarter radius of the sphere");
  return fit;
}

StatusOr<std::vector<SphereFit>> DetectSpheres(const SphereEvidence& ev,
                                               const SphereDetectOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  if (ev.count < 1) return InvalidArgument("no photos");
  const int f = ev.factor;
  const Image small_mean = Downsample(ev.mean, f);
  const int w = small_mean.width(), h = small_mean.height(), side = std::min(w, h);
  const int rmin = std::max(4, int(o.min_radius_frac * side)),
            rmax = std::max(rmin + 1, int(o.max_radius_frac * side));
  const cv::Mat img = Stretched(small_mean, 1.5);
  std::vector<cv::Vec4f> circles;  // x, y, r, votes
  cv::HoughCircles(img, circles, cv::HOUGH_GRADIENT_ALT, 1.5, rmin, 60, 0.7, rmin, rmax);
  // Each photo's brightest pixel, once (the highlight test compares against it).
  std::vector<float> photo_max;
  for (const Image& p : ev.small)
    photo_max.push_back(p.empty() ? 0.0f : *std::max_element(p.data().begin(), p.data().end()));
  std::vector<Candidate> cands;
  for (size_t i = 0; i < circles.size() && i < 40; ++i) {
    Candidate c{circles[i][0], circles[i][1], circles[i][2]};
    // Highlight: the photo's brightest pixel in the disc is a small spot well above the disc's
    // median, and bright against the photo. Only the disc's bounding box is read.
    const double rr = 0.95 * c.r;
    const int x0 = std::max(0, int(c.x - rr)), x1 = std::min(w - 1, int(c.x + rr) + 1),
              y0 = std::max(0, int(c.y - rr)), y1 = std::min(h - 1, int(c.y + rr) + 1);
    int lit = 0;
    std::vector<float> in;
    for (size_t k = 0; k < ev.small.size(); ++k) {
      const Image& p = ev.small[k];
      in.clear();
      float peak = 0;
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
          if (std::hypot(x - c.x, y - c.y) < rr) {
            const float v = p.At(0, y, x);
            in.push_back(v), peak = std::max(peak, v);
          }
      if (in.empty() || !(peak > 0)) continue;
      size_t bright = 0;
      for (float v : in) bright += v >= 0.5f * peak;
      const double med = Percentile(in, 0.5);
      if (bright <= std::max<size_t>(4, in.size() / 50) && peak >= 0.25f * photo_max[k] &&
          peak > 4 * med)
        ++lit;
    }
    c.highlight = double(lit) / double(ev.small.size());
    c.x = (c.x + 0.5) * f - 0.5, c.y = (c.y + 0.5) * f - 0.5, c.r *= f;
    cands.push_back(c);
  }
  // Every candidate with a highlight in most photos is refined; the fits are ranked by that
  // share (in 10 % bands), then by how much of their circle is a clear edge.
  struct Refined {
    SphereFit fit;
    double highlight;
  };
  std::vector<Refined> fits;
  for (const Candidate& c : cands) {
    if (c.highlight < 0.5) continue;  // a mirror sphere shows the light in most photos
    auto fit = RefineSphere(ev.mean, c.x, c.y, c.r);
    // A sphere's silhouette is a circle to a fraction of a pixel; circles that texture or
    // reflections suggest leave edge points far off their fit.
    if (fit.ok() && fit->rms_px <= std::max(1.0, 0.01 * fit->radius))
      fits.push_back({*fit, c.highlight});
  }
  std::sort(fits.begin(), fits.end(), [](const Refined& a, const Refined& b) {
    const int ha = int(a.highlight * 10), hb = int(b.highlight * 10);
    if (ha != hb) return ha > hb;
    return a.fit.edge_coverage > b.fit.edge_coverage;
  });
  std::vector<SphereFit> out;
  for (const Refined& r : fits) {
    if (int(out.size()) == o.spheres) break;
    bool overlaps = false;
    for (const SphereFit& s : out)
      overlaps |= std::hypot(r.fit.cx - s.cx, r.fit.cy - s.cy) < r.fit.radius + s.radius;
    if (!overlaps) out.push_back(r.fit);
  }
  if (int(out.size()) < o.spheres)
    return DataError("found " + std::to_string(out.size()) + " of " + std::to_string(o.spheres) +
                     " reflective sphere(s) in the photos (" + std::to_string(cands.size()) +
                     " round shapes; a mirror sphere also shows the light as a small spot in "
                     "at least half the photos); give the sphere as --sphere X,Y,R (pixels)");
  return out;
}

}  // namespace matfit::capture
