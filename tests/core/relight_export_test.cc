// The relight / OpenLIME web layout (core/pack/relight_export.h, written by WritePackExports)
// read back by a reader written here from the format as relight-cli writes it and OpenLIME's
// ShaderRTI reads it: info.json gives width, height, type (ptm | hsh), colorspace (rgb), nplanes
// and materials[0].scale / bias (one per plane); image plane_i.jpg holds planes 3i, 3i+1, 3i+2
// in its r, g, b; plane p = 3·j + c is term j of channel c; coefficient = (code/255 − bias_p) ×
// scale_p; a channel's value is Σ_j coefficient_j w_j(l). The weights are written out again
// below from the published formulas: ptm 1, x, y, x², xy, y² (by degree, then by the power of y);
// hsh the RTI tools' hemispherical harmonics.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "core/pack/pack_exports.h"
#include "core/pack/relight_export.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

void Weights(const std::string& type, int terms, double lx, double ly, double lz, double* w) {
  if (type == "ptm") {
    const double all[6] = {1, lx, ly, lx * lx, lx * ly, ly * ly};
    for (int i = 0; i < terms; ++i) w[i] = all[i];
    return;
  }
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

struct WebRead {
  nlohmann::json info;
  std::string type;
  int w = 0, h = 0, nplanes = 0;
  std::vector<double> scale, bias;
  std::vector<std::vector<float>> planes;  // [plane][y * w + x]: code / 255

  double Coefficient(int p, int64_t t) const {
    return (planes[size_t(p)][size_t(t)] - bias[size_t(p)]) * scale[size_t(p)];
  }
  double Eval(int x, int y, int c, double lx, double ly, double lz) const {
    double wt[9];
    const int terms = nplanes / 3;
    Weights(type, terms, lx, ly, lz, wt);
    double v = 0;
    for (int j = 0; j < terms; ++j) v += Coefficient(3 * j + c, int64_t(y) * w + x) * wt[j];
    return v;
  }
};

WebRead Read(const fs::path& dir) {
  WebRead r;
  std::ifstream f(dir / "info.json");
  r.info = nlohmann::json::parse(f);
  r.type = r.info.at("type");
  r.w = r.info.at("width"), r.h = r.info.at("height"), r.nplanes = r.info.at("nplanes");
  EXPECT_EQ(r.info.at("colorspace"), "rgb");
  EXPECT_EQ(r.info.at("format"), "jpg");
  const auto& mat = r.info.at("materials").at(0);
  for (int p = 0; p < r.nplanes; ++p)
    r.scale.push_back(mat.at("scale").at(p)), r.bias.push_back(mat.at("bias").at(p));
  r.planes.resize(size_t(r.nplanes));
  ImageReadOptions linear;
  linear.color_space = ColorSpaceChoice::kLinear;  // codes as they are
  for (int i = 0; 3 * i < r.nplanes; ++i) {
    auto img = ReadImage((dir / ("plane_" + std::to_string(i) + ".jpg")).string(), linear);
    EXPECT_TRUE(img.ok()) << img.status().ToString();
    if (!img.ok()) return r;
    EXPECT_EQ(img->width(), r.w);
    EXPECT_EQ(img->height(), r.h);
    EXPECT_EQ(img->channels(), 3);
    for (int c = 0; c < 3 && 3 * i + c < r.nplanes; ++c)
      r.planes[size_t(3 * i + c)].assign(img->Plane(c).begin(), img->Plane(c).end());
  }
  return r;
}

MaterialMaps RandomFit(ShadingModel model, int w, int h, int channels, int terms, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f), base(0.5f, 1.5f);
  MaterialMaps m;
  m.width = w, m.height = h, m.model = model, m.basis_terms = terms;
  m.coefficients = Image(w, h, channels * terms);
  // A smooth field plus texel noise: what fitted coefficient maps look like.
  for (int q = 0; q < channels * terms; ++q)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        m.coefficients.At(q, y, x) =
            (q % terms == (model == ShadingModel::kPtm ? 5 : 0) ? base(rng) : u(rng)) * 0.5f +
            0.1f * std::sin(0.3 * x + q) * std::cos(0.2 * y);
  return m;
}

// The fit's own value at (x, y), channel c, light l.
double FitValue(const MaterialMaps& m, int x, int y, int c, const Vec3& l) {
  double wt[shading::kMaxHshTerms];
  if (m.model == ShadingModel::kPtm)
    shading::PtmBasis(l, wt);
  else
    shading::HshBasis(m.basis_terms == 4 ? 2 : 3, l, wt);
  const int ch = m.coefficients.channels() / m.basis_terms;
  double v = 0;
  for (int j = 0; j < m.basis_terms; ++j)
    v += m.coefficients.At((ch == 3 ? c : 0) * m.basis_terms + j, y, x) * wt[j];
  return v;
}

struct Errors {
  double worst_steps = 0;  // max |file coefficient − fit's| in code steps (scale / 255)
  double mean_steps = 0;   // mean of the same
  double worst_ratio = 0;  // max |file value − fit value| / (half a step per term + JPEG)
  double worst_value = 0;
};

// Writes the layout through the pack's own writer (JPEG planes) and reads it back.
Errors RoundTrip(const MaterialMaps& m, double jpeg_steps) {
  testing::TempDir tmp;
  nlohmann::json exports = nlohmann::json::array();
  const Status s = WritePackExports(m, tmp.path(), &exports);
  EXPECT_TRUE(s.ok()) << s.ToString();
  bool listed = false;
  for (const auto& e : exports) listed |= e.at("file") == "relight/info.json";
  EXPECT_TRUE(listed) << exports.dump();
  const WebRead r = Read(fs::path(tmp.path()) / "relight");
  EXPECT_EQ(r.type, m.model == ShadingModel::kPtm ? "ptm" : "hsh");
  EXPECT_EQ(r.w, m.width);
  EXPECT_EQ(r.h, m.height);
  EXPECT_EQ(r.nplanes, 3 * m.basis_terms);
  Errors e;
  if (r.planes.empty() || r.planes.back().size() != size_t(m.width) * m.height) return e;
  // Coefficients: the layout's term j is the fit's term under a fixed relabelling; compare
  // values instead (basis-independent) and coefficient errors through the term-0 plane map.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> th(0, 1.4), ph(0, 2 * std::numbers::pi);
  const int terms = m.basis_terms;
  double sum_steps = 0;
  int64_t count = 0;
  for (int k = 0; k < 30; ++k) {
    const double t = th(rng), p = ph(rng);
    const Vec3 l{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    double wt[9];
    Weights(r.type, terms, l.x, l.y, l.z, wt);
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        for (int c = 0; c < 3; ++c) {
          double bound = 0;
          for (int j = 0; j < terms; ++j)
            bound += r.scale[size_t(3 * j + c)] / 255.0 * (0.5 + jpeg_steps) * std::abs(wt[j]);
          const double got = r.Eval(x, y, c, l.x, l.y, l.z), want = FitValue(m, x, y, c, l);
          e.worst_value = std::max(e.worst_value, std::abs(got - want));
          e.worst_ratio = std::max(e.worst_ratio, std::abs(got - want) / (bound * 1.001 + 1e-12));
        }
  }
  // The constant term is the same function in both bases (1 for ptm, 1/√(2π) for hsh).
  const int ch = m.coefficients.channels() / terms;
  const int fit_const = m.model == ShadingModel::kPtm ? 5 : 0;
  for (int c = 0; c < 3; ++c)
    for (int64_t t = 0; t < int64_t(m.width) * m.height; ++t) {
      const double want = m.coefficients.Plane((ch == 3 ? c : 0) * terms + fit_const)[t];
      const double steps = std::abs(r.Coefficient(c, t) - want) / (r.scale[size_t(c)] / 255.0);
      e.worst_steps = std::max(e.worst_steps, steps);
      sum_steps += steps, ++count;
    }
  e.mean_steps = sum_steps / double(count);
  return e;
}

// JPEG at quality 100 with 4:4:4 chroma adds at most this many code steps to the exporter's own
// half-step rounding on noise-like planes (measured on these random fields: total error up to 4.4
// steps, mean 0.61; docs/pack.md).
constexpr double kJpegSteps = 4.5;

TEST(RelightExport, PtmAndHshReadBackAsTheFitWithinQuantisation) {
  for (const auto& [model, terms] :
       {std::pair{ShadingModel::kPtm, 6}, std::pair{ShadingModel::kHsh, 4},
        std::pair{ShadingModel::kHsh, 9}}) {
    const Errors e = RoundTrip(RandomFit(model, 37, 23, 3, terms, unsigned(terms)), kJpegSteps);
    SCOPED_TRACE(terms);
    EXPECT_LE(e.worst_ratio, 1.0) << "worst |file − fit| " << e.worst_value;
    EXPECT_LE(e.worst_steps, 0.5 + kJpegSteps);
    EXPECT_LE(e.mean_steps, 0.75) << "JPEG q100 should stay near the half-step rounding";
    std::printf("relight %s %d terms: coefficient error mean %.3f max %.2f steps\n",
                model == ShadingModel::kPtm ? "ptm" : "hsh", terms, e.mean_steps, e.worst_steps);
  }
}

TEST(RelightExport, InMemoryPlanesAreExactToHalfAStep) {
  const MaterialMaps m = RandomFit(ShadingModel::kHsh, 11, 7, 3, 9, 3);
  auto web = EncodeRelightWeb(m);
  ASSERT_TRUE(web.ok()) << web.status().ToString();
  const auto info = nlohmann::json::parse(web->info_json);
  ASSERT_EQ(web->planes.size(), 9u);
  const auto& mat = info.at("materials").at(0);
  // Term 0 (constant) of each channel sits in plane_0's r, g, b.
  for (int c = 0; c < 3; ++c) {
    const double sc = mat.at("scale").at(c), bi = mat.at("bias").at(c);
    for (int64_t t = 0; t < 77; ++t) {
      const float v = web->planes[0].Plane(c)[t];
      EXPECT_EQ(v * 255.0f, std::round(v * 255.0f));  // exact codes
      EXPECT_LE(std::abs((v - bi) * sc - m.coefficients.Plane(c * 9)[t]), sc / 255 / 2 * 1.0001);
    }
  }
}

TEST(RelightExport, GreyFitsAreWrittenAsThreeEqualChannels) {
  const Errors e = RoundTrip(RandomFit(ShadingModel::kPtm, 16, 9, 1, 6, 7), kJpegSteps);
  EXPECT_LE(e.worst_ratio, 1.0) << "worst |file − fit| " << e.worst_value;
}

TEST(RelightExport, OtherFitsAreRefused) {
  EXPECT_FALSE(EncodeRelightWeb(RandomFit(ShadingModel::kHsh, 4, 4, 3, 16, 1)).ok());
  MaterialMaps m = RandomFit(ShadingModel::kPtm, 4, 4, 3, 6, 1);
  m.model = ShadingModel::kLambert;
  EXPECT_FALSE(EncodeRelightWeb(m).ok());
}

// Each term's image is made on its own thread: one and two threads give the same planes and
// the same info.json.
TEST(RelightExport, TheSamePlanesOnOneAndTwoThreads) {
  for (auto [model, terms] : {std::pair{ShadingModel::kPtm, 6}, std::pair{ShadingModel::kHsh, 9}}) {
    MaterialMaps m = RandomFit(model, 300, 170, 3, terms, 9);
    m.coefficients.Plane(2)[99] = NAN;
    SetNumThreads(1);
    const auto one = EncodeRelightWeb(m);
    SetNumThreads(2);
    const auto two = EncodeRelightWeb(m);
    SetNumThreads(0);
    ASSERT_TRUE(one.ok() && two.ok());
    EXPECT_EQ(one->info_json, two->info_json);
    ASSERT_EQ(one->planes.size(), size_t(terms));
    ASSERT_EQ(two->planes.size(), size_t(terms));
    for (size_t i = 0; i < one->planes.size(); ++i)
      EXPECT_EQ(one->planes[i].data(), two->planes[i].data()) << "plane image " << i;
  }
}

}  // namespace
}  // namespace matfit
