// HSH .rti export (core/pack/rti_export.h) read back by a reader written here from the format as
// RTIViewer and relight load it: '#' comment lines, the type (3 = HSH), "width height bands",
// "terms basis-type element-size", float32 scale[terms] and bias[terms], then bytes per row
// (bottom row first), per texel, per band, per term; coefficient = byte/255 × scale + bias and
// the value Σ_j coefficient_j w_j(l) with the RTI tools' HSH weights, written out again below
// from the published formulas (not the exporter's function).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/pack/rti_export.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"

namespace matfit {
namespace {

// RTIViewer's HSH weights (Gautron et al. 2004 as RTIBuilder fits them), c = cos θ.
void Weights(int terms, double lx, double ly, double lz, double* w) {
  const double pi = std::numbers::pi, c = std::max(0.0, lz), phi = std::atan2(ly, lx);
  const double r = std::sqrt(std::max(0.0, c - c * c));
  const double all[9] = {1 / std::sqrt(2 * pi),
                         std::sqrt(6 / pi) * std::cos(phi) * r,
                         std::sqrt(3 / (2 * pi)) * (-1 + 2 * c),
                         std::sqrt(6 / pi) * r * std::sin(phi),
                         std::sqrt(30 / pi) * std::cos(2 * phi) * (-c + c * c),
                         std::sqrt(30 / pi) * std::cos(phi) * (-1 + 2 * c) * r,
                         std::sqrt(5 / (2 * pi)) * (1 - 6 * c + 6 * c * c),
                         std::sqrt(30 / pi) * (-1 + 2 * c) * r * std::sin(phi),
                         std::sqrt(30 / pi) * (-c + c * c) * std::sin(2 * phi)};
  for (int i = 0; i < terms; ++i) w[i] = all[i];
}

struct RtiRead {
  int type = 0, w = 0, h = 0, bands = 0, terms = 0, basis = 0, element = 0;
  std::vector<float> scale, bias;
  std::vector<unsigned char> data;

  // Band value at texel (x, y), y = 0 the TOP row (matfit's convention).
  double Eval(int x, int y, int band, double lx, double ly, double lz) const {
    double wt[9];
    Weights(terms, lx, ly, lz, wt);
    const size_t k = (size_t(h - 1 - y) * w + x) * bands * terms + size_t(band) * terms;
    double v = 0;
    for (int i = 0; i < terms; ++i) v += (data[k + i] / 255.0 * scale[i] + bias[i]) * wt[i];
    return v;
  }
};

RtiRead Parse(const std::string& bytes) {
  RtiRead r;
  size_t pos = 0;
  auto line = [&] {
    const size_t e = bytes.find('\n', pos);
    std::string l = bytes.substr(pos, e - pos);
    pos = e + 1;
    return l;
  };
  std::string l = line();
  EXPECT_EQ(l.rfind("#HSH1.2", 0), 0u);
  while (!(l = line()).empty() && l[0] == '#') {
  }
  r.type = std::stoi(l);
  std::istringstream(line()) >> r.w >> r.h >> r.bands;
  std::istringstream(line()) >> r.terms >> r.basis >> r.element;
  r.scale.resize(size_t(r.terms)), r.bias.resize(size_t(r.terms));
  std::memcpy(r.scale.data(), bytes.data() + pos, 4 * size_t(r.terms));
  std::memcpy(r.bias.data(), bytes.data() + pos + 4 * size_t(r.terms), 4 * size_t(r.terms));
  r.data.assign(bytes.begin() + long(pos + 8 * size_t(r.terms)), bytes.end());
  EXPECT_EQ(r.data.size(), size_t(r.w) * r.h * r.bands * r.terms);
  return r;
}

MaterialMaps RandomHsh(int w, int h, int channels, int terms, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f), base(0.5f, 1.5f);
  MaterialMaps m;
  m.width = w, m.height = h, m.model = ShadingModel::kHsh, m.basis_terms = terms;
  m.coefficients = Image(w, h, channels * terms);
  for (int q = 0; q < channels * terms; ++q)
    for (int64_t p = 0; p < int64_t(w) * h; ++p)
      m.coefficients.Plane(q)[p] = q % terms == 0 ? base(rng) : u(rng);
  return m;
}

void Check(const MaterialMaps& m) {
  auto bytes = EncodeRti(m);
  ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
  const RtiRead r = Parse(*bytes);
  EXPECT_EQ(r.type, 3);
  ASSERT_EQ(r.w, m.width);
  ASSERT_EQ(r.h, m.height);
  ASSERT_EQ(r.bands, 3);
  ASSERT_EQ(r.terms, m.basis_terms);
  const int order = m.basis_terms == 4 ? 2 : 3, ch = m.coefficients.channels() / m.basis_terms;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> th(0, 1.4), ph(0, 2 * std::numbers::pi);
  double worst_ratio = 0, worst = 0;
  for (int k = 0; k < 40; ++k) {
    const double t = th(rng), p = ph(rng);
    const Vec3 l{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    double mine[shading::kMaxHshTerms], wt[9];
    shading::HshBasis(order, l, mine);
    Weights(r.terms, l.x, l.y, l.z, wt);
    double bound = 0;  // half a byte step per term
    for (int i = 0; i < r.terms; ++i) bound += r.scale[i] / 255.0 / 2 * std::abs(wt[i]);
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        for (int b = 0; b < 3; ++b) {
          double want = 0;
          for (int j = 0; j < r.terms; ++j)
            want +=
                m.coefficients.Plane((ch == 3 ? b : 0) * r.terms + j)[y * m.width + x] * mine[j];
          const double got = r.Eval(x, y, b, l.x, l.y, l.z);
          worst = std::max(worst, std::abs(got - want));
          worst_ratio = std::max(worst_ratio, std::abs(got - want) / (bound * 1.001 + 1e-9));
        }
  }
  EXPECT_LE(worst_ratio, 1.0) << "worst |file − fit| " << worst;
}

TEST(RtiExport, Order2And3ReadBackAsTheFitWithinQuantisation) {
  Check(RandomHsh(9, 6, 3, 4, 1));
  Check(RandomHsh(7, 10, 3, 9, 2));
}

TEST(RtiExport, GreyFitsAreWrittenAsThreeEqualBands) { Check(RandomHsh(6, 5, 1, 9, 3)); }

TEST(RtiExport, TheRtiBasisIsMatfitsUpToOrderAndSign) {
  const Vec3 l = Normalize(Vec3{-0.2, 0.5, 0.7});
  double mine[shading::kMaxHshTerms], rti[9];
  shading::HshBasis(3, l, mine);
  Weights(9, l.x, l.y, l.z, rti);
  for (int band = 0; band < 3; ++band)
    for (int mm = -band; mm <= band; ++mm)
      EXPECT_NEAR(std::abs(rti[band * band + band - mm]), std::abs(mine[band * band + band + mm]),
                  1e-12)
          << band << " " << mm;
}

TEST(RtiExport, OtherFitsAreRefused) {
  MaterialMaps m = RandomHsh(4, 4, 3, 16, 4);  // order 4: RTI tools stop at 9 terms
  EXPECT_FALSE(EncodeRti(m).ok());
  m = RandomHsh(4, 4, 3, 9, 4);
  m.model = ShadingModel::kPtm;
  EXPECT_FALSE(EncodeRti(m).ok());
}

// Ranges of texels on two threads (a map of several 16384-texel ranges, one coefficient NaN):
// the same bytes as on one, and the file reads back as the fit on two.
TEST(RtiExport, TheSameFileOnOneAndTwoThreads) {
  for (int terms : {4, 9}) {
    MaterialMaps m = RandomHsh(260, 190, 3, terms, 5);
    m.coefficients.Plane(terms + 1)[4321] = NAN;
    SetNumThreads(1);
    const auto one = EncodeRti(m);
    SetNumThreads(2);
    const auto two = EncodeRti(m);
    ASSERT_TRUE(one.ok() && two.ok());
    EXPECT_EQ(*one, *two) << terms << " terms";
    m.coefficients.Plane(terms + 1)[4321] = 0.0f;
    Check(m);
    SetNumThreads(0);
  }
}

}  // namespace
}  // namespace matfit
