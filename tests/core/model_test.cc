// Model descriptors: the registry, batched and scattered evaluation against the per-sample
// definition, pack round trips and shader planes, for every registered model.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "core/image_io.h"
#include "core/model/model.h"
#include "core/pack/pack.h"
#include "core/pack/pack_reader.h"
#include "core/pack/shader_params.h"
#include "core/shading/evaluate.h"
#include "tests/core/model_maps.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

using testing::RandomModelMaps;

// ptm, hsh and rbf: coefficients × a basis of the light (also grey and with an sRGB sum).
bool IsBasisModel(const ModelDescriptor& d) {
  const std::string n = d.name();
  return n == "ptm" || n == "hsh" || n == "rbf";
}

// Directions over the whole sphere, upper hemisphere denser, grazing and below-horizon ones too.
std::vector<Vec3f> TestLights() {
  std::vector<Vec3f> d;
  for (int k = 0; k < 24; ++k) {
    const double z = 1.0 - (k + 0.5) / 24 * 1.3, r = std::sqrt(std::max(0.0, 1 - z * z));
    d.push_back(
        Normalize(Vec3f(float(r * std::cos(2.4 * k)), float(r * std::sin(2.4 * k)), float(z))));
  }
  d.push_back(Vec3f(0, 0, 1));
  d.push_back(Normalize(Vec3f(1, 0, 0.001f)));
  return d;
}

TEST(ModelRegistry, IdsNamesAndLookupsAgree) {
  std::set<std::string> names;
  for (size_t i = 0; i < AllModels().size(); ++i) {
    const ModelDescriptor* m = AllModels()[i];
    EXPECT_EQ(int(m->id()), int(i));
    EXPECT_TRUE(names.insert(m->name()).second) << m->name();
    EXPECT_EQ(FindModel(m->name()), m);
    EXPECT_EQ(ModelId(m->name()), m->id());
    EXPECT_EQ(&Model(m->id()), m);
    EXPECT_STREQ(ShadingModelName(m->id()), m->name());
    // Light-group buffers (score, eval_bench) hold kMaxEvalLightGroup lights' outputs.
    EXPECT_GE(m->light_group(), 1) << m->name();
    EXPECT_LE(m->light_group(), kMaxEvalLightGroup) << m->name();
  }
  EXPECT_EQ(FindModel("no-such-model"), nullptr);
  EXPECT_EQ(AllModels().size(), 9u);
}

// The batched evaluator equals the per-sample definition for every model, light, channel count
// and run alignment (float rounding: the runs sum in float and may contract to FMA).
TEST(ModelBatch, EqualsPerSampleEvaluationForEveryModel) {
  const std::vector<Vec3f> lights = TestLights();
  for (const ModelDescriptor* d : AllModels())
    for (int variant = 0; variant < 4; ++variant) {
      // Basis models also grey, and with an sRGB-encoded basis sum (ptm-srgb, hsh*-srgb).
      const bool grey = variant & 1, srgb = variant & 2;
      if (variant && !IsBasisModel(*d)) continue;
      for (uint32_t seed : {1u, 2u}) {
        MaterialMaps m = RandomModelMaps(d->id(), 23, 7, seed, grey);
        m.basis_srgb = srgb;
        const Vec3f v = seed == 1 ? Vec3f(0, 0, 1) : Normalize(Vec3f(0.3f, -0.2f, 0.9f));
        const BatchEvaluator eval(m, lights, v);
        const int64_t T = int64_t(m.width) * m.height;
        for (int channels : {1, 3})
          for (int64_t p0 : {int64_t(0), int64_t(5)}) {
            const int n = int(std::min<int64_t>(T - p0, 97));
            std::vector<float> out(size_t(3) * n);
            for (int i = 0; i < int(lights.size()); ++i) {
              eval.Evaluate(i, p0, n, channels, out.data());
              for (int c = 0; c < channels; ++c)
                for (int t = 0; t < n; ++t) {
                  const float want = EvaluateTexel(m, p0 + t, c, lights[size_t(i)], v);
                  ASSERT_NEAR(out[size_t(c * n + t)], want, 2e-6 + 2e-6 * std::abs(want))
                      << d->name() << " light " << i << " texel " << p0 + t << " channel " << c;
                }
            }
          }
      }
    }
}

// Groups of lights (BatchEvaluator::EvaluateLights) give exactly Evaluate's values light by light,
// for every model, group size (whole groups of four and remainders), channel count and run length
// (whole 16-texel blocks and tails).
TEST(ModelBatch, LightGroupsEqualSingleLightsExactly) {
  const std::vector<Vec3f> lights = TestLights();  // 26 lights
  for (const ModelDescriptor* d : AllModels())
    for (int variant = 0; variant < 4; ++variant) {
      const bool grey = variant & 1, srgb = variant & 2;
      if (variant && !IsBasisModel(*d)) continue;
      MaterialMaps m = RandomModelMaps(d->id(), 23, 7, 3, grey);
      m.basis_srgb = srgb;
      const BatchEvaluator eval(m, lights, Vec3f(0, 0, 1));
      for (int channels : {1, 3})
        for (int n : {1, 16, 37, 154}) {
          const int64_t p0 = 161 - n;
          std::vector<float> one(size_t(channels) * n), group(size_t(6) * channels * n);
          for (int count : {4, 6, 3}) {
            for (int first = 0; first + count <= int(lights.size()); first += count) {
              eval.EvaluateLights(first, count, p0, n, channels, group.data());
              for (int l = 0; l < count; ++l) {
                eval.Evaluate(first + l, p0, n, channels, one.data());
                for (size_t q = 0; q < one.size(); ++q)
                  ASSERT_EQ(group[size_t(l) * channels * n + q], one[q])
                      << d->name() << " lights " << first << "+" << l << " n " << n;
              }
            }
          }
        }
    }
}

TEST(ModelBatch, ScatteredEvaluationEqualsPerSample) {
  const std::vector<Vec3f> lights = TestLights();
  for (const ModelDescriptor* d : AllModels()) {
    const MaterialMaps m = RandomModelMaps(d->id(), 9, 9, 3);
    std::vector<int64_t> texels;
    std::vector<Vec3f> ls, vs;
    for (int k = 0; k < 60; ++k) {
      texels.push_back((k * 37) % 81);
      ls.push_back(lights[size_t(k) % lights.size()]);
      vs.push_back(lights[size_t(k * 7 + 3) % lights.size()]);
    }
    std::vector<float> out(3 * texels.size());
    d->EvaluateSamples(m, texels.data(), ls.data(), vs.data(), int(texels.size()), out.data());
    for (size_t k = 0; k < texels.size(); ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(out[c * texels.size() + k], d->Evaluate(m, texels[k], c, ls[k], vs[k]))
            << d->name();
  }
}

// Writing a pack and reading it back gives maps that evaluate the same (the exact EXR maps).
TEST(ModelPack, RoundTripEvaluatesTheSameForEveryModel) {
  testing::TempDir dir;
  const std::vector<Vec3f> lights = TestLights();
  for (const ModelDescriptor* d : AllModels())
    for (const bool srgb : {false, true}) {
      if (srgb && !IsBasisModel(*d)) continue;
      MaterialMaps m = RandomModelMaps(d->id(), 8, 6, 2);
      m.basis_srgb = srgb;  // ptm-srgb / hsh*-srgb: material.json basis_srgb
      const std::vector<uint8_t> status(size_t(m.width) * m.height, 0);
      PackInfo info;
      info.method = d->name();
      if (!m.specular_color.empty()) info.model_parameters["exponent"] = m.exponent.data()[0];
      const std::string out = dir / (std::string(d->name()) + (srgb ? "-srgb" : ""));
      ASSERT_TRUE(WritePack(m, status, info, {}, out).ok()) << d->name();
      auto back = ReadPack(out);
      ASSERT_TRUE(back.ok()) << d->name() << ": " << back.status().message();
      EXPECT_EQ(back->maps.model, d->id());
      EXPECT_EQ(back->maps.basis_terms, m.basis_terms);
      EXPECT_EQ(back->maps.basis_srgb, srgb) << d->name();
      EXPECT_EQ(back->maps.basis_table.data(), m.basis_table.data()) << d->name();
      EXPECT_EQ(back->maps.specular_flat_normal, m.specular_flat_normal);
      EXPECT_EQ(d->ParameterPlanes(back->maps), d->ParameterPlanes(m)) << d->name();
      for (int64_t p = 0; p < int64_t(m.width) * m.height; ++p)
        for (const Vec3f& l : lights)
          for (int c = 0; c < 3; ++c) {
            const float want = d->Evaluate(m, p, c, l, Vec3f(0, 0, 1));
            ASSERT_NEAR(d->Evaluate(back->maps, p, c, l, Vec3f(0, 0, 1)), want,
                        1e-6 + 1e-6 * std::abs(want))
                << d->name();
          }
    }
}

// preview.png has no holes (issue #21): a flagged texel shows its maps' estimate like an ok one,
// a texel with no estimate at all (zero normal) is magenta, and only masked texels are black.
TEST(ModelPack, PreviewDrawsFlaggedTexelsAndMarksTexelsWithoutEstimate) {
  testing::TempDir dir;
  MaterialMaps m = RandomModelMaps(ModelId("lambert"), 8, 8, 4);
  for (int64_t p = 0; p < 64; ++p)  // facing up, lit at θ 35°: every unmasked texel is lit
    m.normal.Plane(0)[p] = 0, m.normal.Plane(1)[p] = 0, m.normal.Plane(2)[p] = 1;
  std::vector<uint8_t> status(64, 0);
  const uint8_t kMasked = 1, kFlagged = 2;  // fit/fit_types.h texel status codes
  status[0] = kMasked;
  for (int p = 8; p < 24; ++p) status[size_t(p)] = kFlagged;  // two rows flagged
  m.normal.Plane(2)[20] = 0;                                  // flagged, no normal
  ASSERT_TRUE(WritePack(m, status, {}, {}, dir / "p").ok());
  ImageReadOptions raw;
  raw.color_space = ColorSpaceChoice::kLinear;  // sRGB codes / 255: 0 and 1 stay exact
  auto img = ReadImage(dir / "p/preview.png", raw);
  ASSERT_TRUE(img.ok()) << img.status().message();
  for (int64_t p = 0; p < 64; ++p) {
    const float r = img->Plane(0)[p], g = img->Plane(1)[p], b = img->Plane(2)[p];
    if (p == 0) {
      EXPECT_EQ(r + g + b, 0.0f) << "masked texel";
    } else if (p == 20) {
      EXPECT_TRUE(r == 1.0f && g == 0.0f && b == 1.0f) << "no-estimate texel not magenta";
    } else {  // lit lambert, albedo ≥ 0.05: never black, never the magenta mark
      EXPECT_GT(r + g + b, 0.05f) << "texel " << p << " status " << int(status[size_t(p)]);
      EXPECT_FALSE(r == 1.0f && g == 0.0f && b == 1.0f) << "texel " << p;
    }
  }
}

// A pack with normals carries the height integrated from them (a task of the write's own, run
// beside the other files): material.json lists height_exact and height right after the normal
// maps with the range of height.exr over the fitted texels, and height.png spans that range.
// Without a fitted texel the height is flat.
TEST(ModelPack, HeightMapsComeWithTheirRange) {
  testing::TempDir dir;
  MaterialMaps m = RandomModelMaps(ModelId("lambert"), 24, 16, 3);
  for (int64_t p = 0; p < 24 * 16; ++p) {  // a dome: a relief to integrate
    const double x = (p % 24 - 11.5) / 12, y = (p / 24 - 7.5) / 12;
    const Vec3 n = Normalize(Vec3(0.6 * x, 0.6 * y, 1.0));
    m.normal.Plane(0)[p] = float(n.x), m.normal.Plane(1)[p] = float(n.y);
    m.normal.Plane(2)[p] = float(n.z);
  }
  std::vector<uint8_t> status(24 * 16, 0);
  status[5] = 2;  // flagged: not integrated
  const std::string out = dir / "with";
  ASSERT_TRUE(WritePack(m, status, {}, {}, out).ok());
  std::ifstream in(out + "/material.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  std::vector<std::string> names;
  nlohmann::json range;
  for (const auto& e : j["maps"]) {
    names.push_back(e["name"]);
    if (e["name"] == "height" || e["name"] == "height_exact") {
      EXPECT_EQ(e["channels"], 1);
      if (range.is_null()) range = e["range_texels"];
      EXPECT_EQ(e["range_texels"], range) << "both entries give the same range";
    }
  }
  const auto at = std::find(names.begin(), names.end(), "normal_exact");
  ASSERT_TRUE(at != names.end() && at + 2 < names.end());
  EXPECT_EQ(at[1], "height_exact");
  EXPECT_EQ(at[2], "height");
  auto exact = ReadImage(out + "/maps/height.exr");
  ASSERT_TRUE(exact.ok()) << exact.status().message();
  double lo = 1e30, hi = -1e30;
  for (int64_t p = 0; p < 24 * 16; ++p) {
    if (p == 5) continue;
    lo = std::min(lo, double(exact->Plane(0)[p])), hi = std::max(hi, double(exact->Plane(0)[p]));
  }
  ASSERT_TRUE(range.is_array() && range.size() == 2);
  EXPECT_NEAR(range[0].get<double>(), lo, 1e-6 * (hi - lo));
  EXPECT_NEAR(range[1].get<double>(), hi, 1e-6 * (hi - lo));
  EXPECT_GT(hi - lo, 1.0) << "the dome's relief, in texels";
  ImageReadOptions raw;
  raw.color_space = ColorSpaceChoice::kLinear;
  auto png = ReadImage(out + "/maps/height.png", raw);
  ASSERT_TRUE(png.ok()) << png.status().message();
  for (int64_t p = 0; p < 24 * 16; ++p) {
    if (p == 5) continue;
    ASSERT_NEAR(png->Plane(0)[p], (exact->Plane(0)[p] - lo) / (hi - lo), 1.0 / 65535) << p;
  }

  // Without a fitted texel the height is flat: range [0, 0], height.png mid-grey.
  std::fill(status.begin(), status.end(), uint8_t(2));  // every texel flagged
  const std::string flat = dir / "flat";
  ASSERT_TRUE(WritePack(m, status, {}, {}, flat).ok());
  std::ifstream in2(flat + "/material.json");
  const nlohmann::json j2 = nlohmann::json::parse(in2);
  int entries = 0;
  for (const auto& e : j2["maps"]) {
    if (e["name"] != "height" && e["name"] != "height_exact") continue;
    ++entries;
    EXPECT_EQ(e["range_texels"], nlohmann::json::array({0.0, 0.0}));
  }
  EXPECT_EQ(entries, 2);
  auto mid = ReadImage(flat + "/maps/height.png", raw);
  ASSERT_TRUE(mid.ok()) << mid.status().message();
  for (int64_t p = 0; p < 24 * 16; ++p) ASSERT_NEAR(mid->Plane(0)[p], 0.5f, 1.0 / 65535) << p;
  EXPECT_TRUE(ReadPack(flat).ok());
}

// Writes `text` as the pack's material.json and expects ReadPack to refuse it, naming the file
// and saying `want`.
void ExpectPackRefused(const std::string& pack, const std::string& text, const std::string& want) {
  testing::WriteText(pack + "/material.json", text);
  auto back = ReadPack(pack);
  ASSERT_FALSE(back.ok()) << text;
  EXPECT_NE(back.status().message().find(want), std::string::npos) << back.status().message();
  EXPECT_NE(back.status().message().find("material.json"), std::string::npos);
}

// A pack whose basis_terms or coefficient planes do not fit its model is refused with the field
// and the allowed values, never evaluated.
TEST(ModelPack, ReaderRefusesInconsistentBasisTerms) {
  testing::TempDir dir;
  const MaterialMaps m = RandomModelMaps(ModelId("hsh"), 6, 5, 1);  // 9 terms, 27 planes
  const std::vector<uint8_t> status(30, 0);
  const std::string out = dir / "hsh";
  ASSERT_TRUE(WritePack(m, status, {}, {}, out).ok());
  const std::string mj = out + "/material.json";
  std::ifstream in(mj);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_NE(good.find("\"basis_terms\": 9"), std::string::npos);
  for (const auto& [terms, want] :
       std::vector<std::pair<std::string, std::string>>{{"5", "must be 1, 4, 9 or 16"},
                                                        {"4", "needs 4 (grey) or 12 (RGB)"},
                                                        {"9.5", "a whole number from 1 to 16"},
                                                        {"1e10", "a whole number from 1 to 16"}}) {
    std::string text = good;
    text.replace(text.find("\"basis_terms\": 9"), 17, "\"basis_terms\": " + terms);
    ExpectPackRefused(out, text, want);
  }
}

// An rbf pack without its basis table, or with one that does not match basis_terms, is refused
// with an error naming the table.
TEST(ModelPack, ReaderRefusesAMissingOrMismatchedRbfTable) {
  testing::TempDir dir;
  const MaterialMaps m = RandomModelMaps(ModelId("rbf"), 6, 5, 1);  // 9 terms, 9 × 9 table
  const std::vector<uint8_t> status(30, 0);
  const std::string out = dir / "rbf";
  ASSERT_TRUE(WritePack(m, status, {}, {}, out).ok());
  ASSERT_TRUE(ReadPack(out).ok());
  const std::string mj = out + "/material.json";
  std::ifstream in(mj);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ImageWriteOptions exr;
  exr.format = PixelFormat::kFloat;
  // Writes the pack's material.json and two maps, then expects ReadPack to refuse it with `want`.
  auto refused = [&](const std::string& text, const Image& table, const Image& coefficients,
                     const std::string& want) {
    testing::WriteText(mj, text);
    ASSERT_TRUE(WriteImage(out + "/maps/basis_table.exr", table, exr).ok());
    ASSERT_TRUE(WriteImage(out + "/maps/coefficients.exr", coefficients, exr).ok());
    auto back = ReadPack(out);
    ASSERT_FALSE(back.ok()) << want;
    EXPECT_NE(back.status().message().find(want), std::string::npos) << back.status().message();
  };
  std::string terms17 = good;
  terms17.replace(terms17.find("\"basis_terms\": 9"), 16, "\"basis_terms\": 17");
  refused(terms17, m.basis_table, m.coefficients, "a whole number from 1 to 16");
  refused(good, Image(9, 9, 4, 0.5f), m.coefficients, "basis table is 9 x 9 with 4 channel(s)");
  // Coefficients of another size than the material (a hostile pack): refused, not read past.
  refused(good, m.basis_table, Image(3, 2, 27, 0.1f), "must be the material's size (6 x 5)");
  std::string unlisted = good;  // the table not listed in material.json
  const size_t at = unlisted.find("\"name\": \"basis_table\"");
  ASSERT_NE(at, std::string::npos);
  unlisted.replace(at, 21, "\"name\": \"basis_tablX\"");
  refused(unlisted, m.basis_table, m.coefficients, "needs its basis table");
}

// pack_fuzzer found a material.json whose model.name was a number: nlohmann threw type_error
// out of ReadPack. Every mistyped field is now an error naming it, and a map may not point
// outside the pack.
TEST(ModelPack, ReaderRefusesMistypedFieldsAndMapsOutsideThePack) {
  testing::TempDir dir;
  const MaterialMaps m = RandomModelMaps(ModelId("lambert"), 6, 5, 1);
  const std::string out = dir / "lambert";
  ASSERT_TRUE(WritePack(m, std::vector<uint8_t>(30, 0), {}, {}, out).ok());
  ASSERT_TRUE(ReadPack(out).ok());
  const std::string maps = R"("maps": [{"name": "albedo", "file": "maps/albedo.png"}])";
  for (const auto& [text, want] : std::vector<std::pair<std::string, std::string>>{
           {R"({"schema": 1, "model": {"name": "lambert"}, )" + maps + "}", "field 'schema'"},
           {R"({"schema": "matfit.material/1", "model": 3, )" + maps + "}", "field 'model'"},
           {R"({"schema": "matfit.material/1", "model": {"name": 5}, )" + maps + "}",
            "field 'model.name' must be a string"},
           {R"({"schema": "matfit.material/1", "model": {"name": "lambert", "method": []}, )" +
                maps + "}",
            "field 'model.method' must be a string"},
           {R"({"schema": "matfit.material/1", "model": {"name": "lambert"},
                "maps": [{"name": 7, "file": "maps/albedo.png"}]})",
            "needs a string 'name' and 'file'"},
           {R"({"schema": "matfit.material/1", "model": {"name": "lambert"},
                "maps": [{"name": "albedo", "file": "../../etc/passwd"}]})",
            "points outside the pack"},
           {R"({"schema": "matfit.material/1", "model": {"name": "lambert"},
                "maps": [{"name": "albedo", "file": "/etc/passwd"}]})",
            "points outside the pack"}}) {
    ExpectPackRefused(out, text, want);
  }
}

// A map of another size than the albedo (status, normal, mask…) is refused by name, never read
// past its end; a map reached through a link out of the pack is refused, never opened.
TEST(ModelPack, ReaderRefusesMapsOfAnotherSizeAndLinksOutOfThePack) {
  testing::TempDir dir;
  const MaterialMaps m = RandomModelMaps(ModelId("lambert"), 6, 5, 1);
  const std::string out = dir / "lambert";
  ASSERT_TRUE(WritePack(m, std::vector<uint8_t>(30, 0), {}, {}, out).ok());
  namespace fs = std::filesystem;
  ImageWriteOptions png, exr;
  png.format = PixelFormat::kUint8, exr.format = PixelFormat::kFloat;
  for (const char* file : {"status.png", "mask.png", "normal.exr"}) {
    const bool is_exr = std::string(file).ends_with(".exr");
    ASSERT_TRUE(WriteImage(out + "/maps/" + file, Image(3, 2, 1, 0.0f), is_exr ? exr : png).ok());
    auto back = ReadPack(out);
    ASSERT_FALSE(back.ok()) << file;
    EXPECT_NE(back.status().message().find("must be the albedo's size (6 x 5)"), std::string::npos)
        << back.status().message();
    ASSERT_TRUE(WritePack(m, std::vector<uint8_t>(30, 0), {}, {}, out + ".again").ok());
    fs::remove_all(out);
    fs::rename(out + ".again", out);
  }
  ASSERT_TRUE(ReadPack(out).ok());
  const std::string outside = dir / "outside.png";
  fs::copy_file(out + "/maps/mask.png", outside);
  fs::remove(out + "/maps/mask.png");
  fs::create_symlink(outside, out + "/maps/mask.png");
  auto back = ReadPack(out);
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.status().message().find("outside"), std::string::npos) << back.status().message();
}

// Every model's shader planes pack; a missing parameter map is named in the error.
TEST(ModelShaderPlanes, PackForEveryModelAndNameAMissingMap) {
  for (const ModelDescriptor* d : AllModels()) {
    MaterialMaps m = RandomModelMaps(d->id(), 5, 4, 1);
    auto sp = PackShaderParams(m);
    ASSERT_TRUE(sp.ok()) << d->name() << ": " << sp.status().message();
    EXPECT_EQ(sp->model, int(d->id()));
    EXPECT_EQ(sp->texels.size(), size_t(sp->layers) * 4 * m.width * m.height);
    const auto maps = d->ParameterMaps(m);
    if (maps.empty()) continue;
    const std::string first = maps.front().first;
    if (first == "normal_scale") continue;  // optional: reads 1 when absent
    // Drop the model's first parameter map: the shaders cannot render without it.
    if (first == "specular") m.specular = Image();
    if (first == "ambient") m.ambient = Image();
    if (first == "coefficients") m.coefficients = Image();
    auto bad = PackShaderParams(m);
    ASSERT_FALSE(bad.ok()) << d->name();
    EXPECT_NE(bad.status().message().find(d->name()), std::string::npos) << bad.status().message();
  }
}

}  // namespace
}  // namespace matfit
