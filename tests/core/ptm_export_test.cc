// .ptm export (core/pack/ptm_export.h) read back by a reader written here from the format
// description (Malzbender & Gelb, PTM file format v1.2): five newline-separated sections — the
// version string, the format string, width and height, six ASCII scales, six ASCII biases — then
// the coefficient bytes, rows bottom to top; a_i = (byte − bias_i) × scale_i and
// C = a0 u² + a1 v² + a2 uv + a3 u + a4 v + a5 in 8-bit code units.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/pack/ptm_export.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"

namespace matfit {
namespace {

struct PtmRead {
  std::string format;
  int w = 0, h = 0;
  double scale[6] = {}, bias[6] = {};
  std::vector<unsigned char> data;

  // C_c(u, v) at texel (x, y) with y = 0 the TOP row of the image (matfit's convention), /255.
  double Eval(int x, int y, int c, double u, double v) const {
    const double basis[6] = {u * u, v * v, u * v, u, v, 1};
    const int64_t n = int64_t(w) * h;
    const int64_t k = int64_t(h - 1 - y) * w + x;  // file order: bottom row first
    auto poly = [&](const unsigned char* b) {
      double s = 0;
      for (int i = 0; i < 6; ++i) s += (b[i] - bias[i]) * scale[i] * basis[i];
      return s;
    };
    if (format == "PTM_FORMAT_RGB") return poly(&data[size_t((c * n + k) * 6)]) / 255;
    const double L = poly(&data[size_t(k * 6)]);
    return L * data[size_t(n * 6 + k * 3 + c)] / 255.0 / 255.0;
  }
};

PtmRead Parse(const std::string& bytes) {
  PtmRead r;
  size_t pos = 0;
  auto line = [&] {
    const size_t e = bytes.find('\n', pos);
    std::string l = bytes.substr(pos, e - pos);
    pos = e + 1;
    while (!l.empty() && l.back() == ' ') l.pop_back();
    return l;
  };
  EXPECT_EQ(line(), "PTM_1.2");
  r.format = line();
  r.w = std::stoi(line());
  r.h = std::stoi(line());
  std::istringstream scales(line()), biases(line());
  for (double& s : r.scale) scales >> s;
  for (double& b : r.bias) biases >> b;
  r.data.assign(bytes.begin() + long(pos), bytes.end());
  const size_t n = size_t(r.w) * r.h;
  EXPECT_EQ(r.data.size(), r.format == "PTM_FORMAT_RGB" ? 18 * n : 9 * n);
  return r;
}

// A 3-channel ptm fit with random coefficients (values in about [0, 1] over the hemisphere);
// with `proportional`, each texel's channels are one polynomial times a colour.
MaterialMaps RandomPtm(int w, int h, int channels, bool proportional, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.2f, 0.2f), base(0.2f, 0.6f), colour(0.2f, 1.0f);
  MaterialMaps m;
  m.width = w, m.height = h, m.model = ShadingModel::kPtm, m.basis_terms = 6, m.basis_srgb = true;
  m.coefficients = Image(w, h, channels * 6);
  for (int64_t p = 0; p < int64_t(w) * h; ++p) {
    float poly[6];
    for (int j = 0; j < 5; ++j) poly[j] = u(rng);
    poly[5] = base(rng);
    for (int c = 0; c < channels; ++c) {
      const float k = proportional ? colour(rng) : 1.0f;
      for (int j = 0; j < 6; ++j)
        m.coefficients.Plane(c * 6 + j)[p] =
            proportional ? k * poly[j] : (j == 5 ? base(rng) : u(rng));
    }
  }
  return m;
}

double Fit(const MaterialMaps& m, int x, int y, int c, double lu, double lv) {
  double b[6];
  shading::PtmBasis(Vec3{lu, lv, std::sqrt(std::max(0.0, 1 - lu * lu - lv * lv))}, b);
  const int ch = m.coefficients.channels() / 6;
  double s = 0;
  for (int j = 0; j < 6; ++j)
    s += m.coefficients.Plane((ch == 3 ? c : 0) * 6 + j)[int64_t(y) * m.width + x] * b[j];
  return s;
}

// Largest |file − fit| over texels, channels and 40 light directions, and the quantisation
// bound Σ_j scale_j / 2 × |B_j| / 255 (plus the colour byte's half step for LRGB).
void Check(const MaterialMaps& m, PtmFormat f) {
  auto bytes = EncodePtm(m, f);
  ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
  const PtmRead r = Parse(*bytes);
  ASSERT_EQ(r.w, m.width);
  ASSERT_EQ(r.h, m.height);
  EXPECT_EQ(r.format, f == PtmFormat::kRgb ? "PTM_FORMAT_RGB" : "PTM_FORMAT_LRGB");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> th(0, 1.3), ph(0, 2 * M_PI);
  double worst = 0, worst_bound_ratio = 0;
  for (int k = 0; k < 40; ++k) {
    const double t = th(rng), p = ph(rng), lu = std::sin(t) * std::cos(p),
                 lv = std::sin(t) * std::sin(p);
    const double basis[6] = {lu * lu, lv * lv, lu * lv, lu, lv, 1};
    double bound = 0;
    for (int j = 0; j < 6; ++j) bound += r.scale[j] / 2 * std::abs(basis[j]) / 255;
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const double want = Fit(m, x, y, c, lu, lv), got = r.Eval(x, y, c, lu, lv);
          // LRGB: the luminance is quantised as above, the colour byte to half a step of 255.
          const double b = f == PtmFormat::kRgb ? bound : bound + std::abs(want) * 0.5 / 255 + 1e-9;
          worst = std::max(worst, std::abs(got - want));
          worst_bound_ratio = std::max(worst_bound_ratio, std::abs(got - want) / (b + 1e-12));
        }
  }
  EXPECT_LE(worst_bound_ratio, 1.0 + 1e-6) << "worst |file − fit| " << worst;
  EXPECT_LT(worst, 0.01);  // a few 8-bit codes at most
}

TEST(PtmExport, RgbReadsBackAsTheFitWithinQuantisation) {
  Check(RandomPtm(13, 7, 3, false, 1), PtmFormat::kRgb);
}

TEST(PtmExport, AGreyFitIsWrittenWithEqualChannels) {
  Check(RandomPtm(5, 9, 1, false, 2), PtmFormat::kRgb);
  Check(RandomPtm(5, 9, 1, false, 3), PtmFormat::kLrgb);
}

TEST(PtmExport, LrgbIsExactWhereTheChromaIsConstant) {
  Check(RandomPtm(11, 6, 3, true, 4), PtmFormat::kLrgb);
}

TEST(PtmExport, RowsAreStoredBottomUp) {
  MaterialMaps m = RandomPtm(2, 2, 3, false, 5);
  for (int j = 0; j < 18; ++j) m.coefficients.Plane(j)[0] = 0;  // top-left texel: all zero
  for (int j = 0; j < 18; ++j) m.coefficients.Plane(j)[2] = 1;  // bottom-left texel: all one
  auto bytes = EncodePtm(m, PtmFormat::kRgb);
  ASSERT_TRUE(bytes.ok());
  const PtmRead r = Parse(*bytes);
  // The first texel of the file is the bottom-left one: every term at its largest code.
  for (int j = 0; j < 6; ++j) EXPECT_EQ(r.data[size_t(j)], 255) << j;
}

TEST(PtmExport, OtherModelsAreRefused) {
  MaterialMaps m = RandomPtm(4, 4, 3, false, 6);
  m.model = ShadingModel::kHsh;
  EXPECT_FALSE(EncodePtm(m, PtmFormat::kRgb).ok());
  m = RandomPtm(4, 4, 3, false, 6);
  m.coefficients = Image(4, 4, 12);
  EXPECT_FALSE(EncodePtm(m, PtmFormat::kRgb).ok());
}

// The encoders split the texels over threads (ranges of 16384): a map of several ranges, with a
// non-finite coefficient, gives the same bytes on one and on two threads, and reads back as the
// fit within quantisation on two.
TEST(PtmExport, TheSameFileOnOneAndTwoThreads) {
  MaterialMaps m = RandomPtm(300, 170, 3, true, 11);
  const float kept = m.coefficients.Plane(4)[777];
  m.coefficients.Plane(4)[777] = NAN;
  for (PtmFormat f : {PtmFormat::kRgb, PtmFormat::kLrgb}) {
    SetNumThreads(1);
    const auto one = EncodePtm(m, f);
    SetNumThreads(2);
    const auto two = EncodePtm(m, f);
    SetNumThreads(0);
    ASSERT_TRUE(one.ok() && two.ok());
    EXPECT_EQ(*one, *two) << (f == PtmFormat::kRgb ? "RGB" : "LRGB");
  }
  m.coefficients.Plane(4)[777] = kept;  // constant chroma again: LRGB is exact to quantisation
  SetNumThreads(2);
  {
    SCOPED_TRACE("RGB");
    Check(m, PtmFormat::kRgb);
  }
  {
    SCOPED_TRACE("LRGB");
    Check(m, PtmFormat::kLrgb);
  }
  SetNumThreads(0);
}

}  // namespace
}  // namespace matfit
