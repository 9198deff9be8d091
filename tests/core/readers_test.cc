// Round trip of every reader on synthetic datasets written in that layout.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

struct LayoutCase {
  Layout layout;
  int bits;
  const char* material;
};

synth::SynthResult Make(const LayoutCase& c, int size = 16) {
  synth::SynthOptions o;
  o.material = c.material;
  o.lights = c.layout == Layout::kBonn ? "bonn81" : "dome:20";
  o.size = size;
  o.layout = c.layout;
  o.bits = c.bits;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return std::move(*r);
}

class ReaderRoundTrip : public ::testing::TestWithParam<LayoutCase> {};

TEST_P(ReaderRoundTrip, ReadsBackWhatWasWritten) {
  const LayoutCase& c = GetParam();
  TempDir tmp;
  const synth::SynthResult r = Make(c);
  const std::string dir = tmp / "obj";
  fs::create_directories(dir);
  DatasetWriteOptions wo;
  wo.layout = c.layout;
  wo.bits = c.bits;
  wo.object_name = "obj";
  ASSERT_TRUE(WriteDataset(r.stack, wo, dir).ok());

  std::string reason;
  auto detected = DetectLayout(dir, &reason);
  ASSERT_TRUE(detected.ok()) << detected.status().ToString();
  EXPECT_EQ(*detected, c.layout) << reason;

  auto back = ReadDataset(dir);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->layout, LayoutName(c.layout));
  ASSERT_EQ(back->num_images(), r.stack.num_images());
  ASSERT_EQ(back->width(), r.stack.width());
  // Lights: same set; BTF readers sort by (θ, φ), the others keep file order.
  for (int i = 0; i < back->num_images(); ++i) {
    double best = 1e9;
    for (const auto& l : r.stack.lights())
      best = std::min(best, AngleBetweenDeg(l.direction, back->lights()[i].direction));
    EXPECT_LT(best, 1e-6) << "light " << i;
  }
  if (c.layout != Layout::kBonn && c.layout != Layout::kUtia) {
    for (int i = 0; i < back->num_images(); ++i)
      EXPECT_LT(AngleBetweenDeg(back->lights()[i].direction, r.stack.lights()[i].direction), 1e-6);
    // Pixels: exact for float EXR, within half a code for 16-bit linear.
    const double tol = c.bits == 32 ? 0.0 : 0.5 / 65535.0 + 1e-7;
    LightStack clamped = r.stack;
    if (c.bits != 32)
      for (int64_t i = 0; i < clamped.plane_size() * 3 * clamped.num_images(); ++i)
        clamped.data()[i] = std::clamp(clamped.data()[i], 0.0f, 1.0f);
    EXPECT_LE(testing::MaxAbsDiff(*back, clamped), tol);
  }
  if (c.layout == Layout::kDiligent && !r.stack.has_mask()) {
    // DiLiGenT always carries mask.png; an unmasked stack is written as all ones.
    ASSERT_TRUE(back->has_mask());
    EXPECT_EQ(back->MaskedTexels(), back->plane_size());
  } else {
    EXPECT_EQ(back->has_mask(), r.stack.has_mask());
  }
  if (r.stack.has_mask()) {
    EXPECT_EQ(back->mask, r.stack.mask);
  }
}

INSTANTIATE_TEST_SUITE_P(Layouts, ReaderRoundTrip,
                         ::testing::Values(LayoutCase{Layout::kBonn, 16, "plaster"},
                                           LayoutCase{Layout::kUtia, 32, "plastic"},
                                           LayoutCase{Layout::kLp, 32, "leaf"},
                                           LayoutCase{Layout::kLp, 16, "wool"},
                                           LayoutCase{Layout::kDiligent, 16, "granite"},
                                           LayoutCase{Layout::kLightsTxt, 32, "leaf"}),
                         [](const auto& param_info) {
                           std::string n = std::string(LayoutName(param_info.param.layout)) +
                                           std::to_string(param_info.param.bits) +
                                           param_info.param.material;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

// Bonn: pixel order is by (θ, φ); compare against the sorted synthetic lights.
TEST(BonnReader, SortsByAngleAndKeepsPixels) {
  TempDir tmp;
  const synth::SynthResult r = Make({Layout::kBonn, 32, "plastic"});
  ASSERT_TRUE(WriteDataset(r.stack, {Layout::kBonn, 32, "x"}, tmp.path()).ok());
  auto back = ReadDataset(tmp.path());
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  // bonn81 is generated in (θ, φ) order already, so the order must be identical.
  for (int i = 0; i < 81; ++i) {
    EXPECT_DOUBLE_EQ(back->lights()[i].theta_deg, r.stack.lights()[i].theta_deg);
    EXPECT_DOUBLE_EQ(back->lights()[i].phi_deg, r.stack.lights()[i].phi_deg);
  }
  EXPECT_EQ(testing::MaxAbsDiff(*back, r.stack), 0.0);
  EXPECT_EQ(back->lights()[0].theta_deg, 0.0);  // sample #1 is θl = 0
}

TEST(BonnReader, SelectsTheRequestedViewOrTheMostFrontal) {
  TempDir tmp;
  synth::SynthResult r = Make({Layout::kBonn, 16, "plaster"});
  ASSERT_TRUE(WriteDataset(r.stack, {Layout::kBonn, 16, "x"}, tmp.path()).ok());
  LightStack oblique = r.stack;
  oblique.view_theta_deg = 30, oblique.view_phi_deg = 60;
  for (int64_t i = 0; i < oblique.plane_size() * 3 * 81; ++i) oblique.data()[i] *= 0.5f;
  ASSERT_TRUE(WriteDataset(oblique, {Layout::kBonn, 16, "x"}, tmp.path()).ok());
  ASSERT_TRUE(fs::is_directory(tmp / "tv030_pv060"));

  auto frontal = ReadDataset(tmp.path());
  ASSERT_TRUE(frontal.ok());
  EXPECT_EQ(frontal->view_theta_deg, 0.0);
  ReadOptions o;
  o.view = ViewAngles{30, 60};
  auto v = ReadDataset(tmp.path(), o);
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  EXPECT_EQ(v->view_theta_deg, 30.0);
  EXPECT_NEAR(AngleBetweenDeg(v->view_direction, DirectionFromAnglesDeg(30, 60)), 0.0, 1e-9);
  EXPECT_NEAR(v->Sample(5, 1, 3 * 16 + 3), 0.5f * frontal->Sample(5, 1, 3 * 16 + 3), 1e-4);
  o.view = ViewAngles{45, 0};
  auto missing = ReadDataset(tmp.path(), o);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("available views"), std::string::npos);
  EXPECT_NE(missing.status().message().find("30,60"), std::string::npos)
      << missing.status().message();
}

TEST(BonnReader, RejectsLightsThatAreNotIntegerDegrees) {
  TempDir tmp;
  synth::SynthOptions o;
  o.lights = "random:5";
  o.layout = Layout::kLp;
  o.size = 8;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  Status st = WriteDataset(r->stack, {Layout::kBonn, 16, "x"}, tmp.path());
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("integer degrees"), std::string::npos);
}

TEST(ReadDataset, EightBitDatasetsAreLinearisedFromSrgb) {
  TempDir tmp;
  synth::SynthResult r = Make({Layout::kLp, 8, "plaster"});
  ASSERT_TRUE(WriteDataset(r.stack, {Layout::kLp, 8, "x"}, tmp.path()).ok());
  auto back = ReadDataset(tmp.path());
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->encodings[0].transfer, TransferFunction::kSrgb);
  // Quantisation error is half an sRGB code, converted to linear: ≤ 0.5/255 · max dL/dE
  // (≈ 2.4 near white) ≈ 0.0047.
  EXPECT_EQ(back->sample_type(), SampleType::kUint8);  // held at the files' depth
  const LightStack f = back->ToFloat();
  double worst = 0;
  for (int64_t i = 0; i < f.plane_size() * 3 * f.num_images(); ++i)
    worst =
        std::max(worst, double(std::abs(f.data()[i] - std::clamp(r.stack.data()[i], 0.0f, 1.0f))));
  EXPECT_LT(worst, 0.0048);
  EXPECT_GT(worst, 0.0);  // it really was quantised
}

TEST(ReadDataset, ColorSpaceOverrideReachesEveryImage) {
  TempDir tmp;
  synth::SynthResult r = Make({Layout::kLp, 8, "plaster"});
  ASSERT_TRUE(WriteDataset(r.stack, {Layout::kLp, 8, "x"}, tmp.path()).ok());
  ReadOptions o;
  o.color_space = ColorSpaceChoice::kLinear;
  auto back = ReadDataset(tmp.path(), o);
  ASSERT_TRUE(back.ok());
  for (const auto& e : back->encodings) EXPECT_EQ(e.transfer, TransferFunction::kLinear);
  EXPECT_GT(back->Sample(0, 0, 0), r.stack.At(0, 0, 0, 0) + 0.1);  // undecoded sRGB is brighter
}

}  // namespace
}  // namespace matfit
