// A model the lights cannot support warns and is never chosen by --model auto (issue 19).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/warnings.h"
#include "fit/assess.h"
#include "fit/light_cover.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/select.h"
#include "synth_data.h"

namespace matfit::fit {
namespace {

std::vector<LightSample> Lights(const std::vector<std::pair<double, double>>& theta_phi) {
  std::vector<LightSample> out;
  for (const auto& [t, p] : theta_phi) {
    LightSample l;
    l.direction = DirectionFromAnglesDeg(t, p), l.theta_deg = t, l.phi_deg = p;
    out.push_back(l);
  }
  return out;
}

bool HasOverfitWarning(const FitResult& r) {
  for (const std::string& w : r.warnings)
    if (w.rfind(WarningName(WarningCode::kOverfitRisk), 0) == 0) return true;
  return false;
}

TEST(LightCover, CountsLightsPerCoefficientAndTheBasisConditioning) {
  // A dome of 40: every model is supported.
  std::vector<std::pair<double, double>> dome, quadrant, twelve;
  for (int k = 0; k < 40; ++k) dome.push_back({10 + 60.0 * (k % 5) / 4, 360.0 * k / 40});
  for (const std::string& name : MethodNames())
    EXPECT_EQ(LightCoverShortfall(Lights(dome), *MakeMethod(name)), "") << name;
  // 12 lights: hsh3's 9 coefficients need 18; ptm's 6 need 12 (met).
  for (int k = 0; k < 12; ++k) twelve.push_back({20 + 20.0 * (k % 3), 30.0 * k});
  const std::string hsh3 = LightCoverShortfall(Lights(twelve), *MakeMethod("hsh3"));
  EXPECT_NE(hsh3.find("9 light-dependent coefficients per texel from 12 lights"), std::string::npos)
      << hsh3;
  EXPECT_EQ(LightCoverShortfall(Lights(twelve), *MakeMethod("ptm")), "");
  EXPECT_EQ(LightCoverShortfall(Lights(twelve), *MakeMethod("lambert")), "");
  // 40 lights crowded into one quadrant, 5–30° from the axis: enough of them, but hsh3's basis
  // is barely determined.
  for (int k = 0; k < 40; ++k) quadrant.push_back({5 + 25.0 * (k % 5) / 4, 90.0 * (k / 5) / 7});
  const double cond = RelightBasisCondition(Lights(quadrant), "hsh3");
  EXPECT_GT(cond, kMaxBasisCondition);
  const std::string q = LightCoverShortfall(Lights(quadrant), *MakeMethod("hsh3"));
  EXPECT_NE(q.find("condition number"), std::string::npos) << q;
  EXPECT_EQ(RelightBasisCondition(Lights(quadrant), "lambert"), 0.0);
}

// No other elevation checks a lobe fitted under one: a ring of 12 at 45° supports lambert and
// not the lobe models; a 5° spread of elevations is enough. The fit then claims no bound.
TEST(LightCover, LobeModelsNeedMoreThanOneElevation) {
  std::vector<std::pair<double, double>> ring, two;
  for (int k = 0; k < 12; ++k)
    ring.push_back({45, 30.0 * k}), two.push_back({40 + 5.0 * (k % 2), 30.0 * k});
  for (const char* name : {"blinn-phong", "cook-torrance", "lafortune1", "lafortune2"}) {
    const std::string why = LightCoverShortfall(Lights(ring), *MakeMethod(name));
    EXPECT_NE(why.find("no other elevation checks"), std::string::npos) << name << ": " << why;
    EXPECT_EQ(LightCoverShortfall(Lights(two), *MakeMethod(name)), "") << name;
  }
  EXPECT_EQ(LightCoverShortfall(Lights(ring), *MakeMethod("lambert")), "");
  // The learned basis interpolates between its lights: 40 on one ring are enough lights for its
  // 9 coefficients, but say nothing of other elevations.
  std::vector<std::pair<double, double>> ring40, two40;
  for (int k = 0; k < 40; ++k)
    ring40.push_back({45, 9.0 * k}), two40.push_back({40 + 5.0 * (k % 2), 9.0 * k});
  for (const char* name : {"rbf", "rbf-srgb"}) {
    const std::string why = LightCoverShortfall(Lights(ring40), *MakeMethod(name));
    EXPECT_NE(why.find("interpolation across elevations"), std::string::npos) << why;
    EXPECT_EQ(LightCoverShortfall(Lights(two40), *MakeMethod(name)), "") << name;
  }
  const auto data = SynthData({.material = "plastic", .lights = "ring12", .size = 12});
  auto method = MakeMethod("blinn-phong");
  auto fit = method->Fit(data.stack, {});
  ASSERT_TRUE(fit.ok());
  const FitAssessment a = AssessFit(data.stack, *method, &*fit);
  EXPECT_TRUE(HasOverfitWarning(*fit));
  for (size_t p = 0; p < fit->status.size(); ++p) {
    EXPECT_EQ(fit->status[p], kTexelUnverifiable);
    EXPECT_TRUE(std::isinf(a.confidence.bound[p]));
  }
}

// The fit says so (summary and report.json warnings); a supported model does not.
TEST(LightCover, AFitWithTooFewLightsPerCoefficientWarns) {
  const auto data = SynthData({.material = "plaster", .lights = "dome:12", .size = 16});
  for (const char* name : {"hsh3", "lambert", "ptm"}) {
    auto method = MakeMethod(name);
    auto fit = method->Fit(data.stack, {});
    ASSERT_TRUE(fit.ok()) << name;
    AssessFit(data.stack, *method, &*fit);
    EXPECT_EQ(HasOverfitWarning(*fit), std::string(name) == "hsh3") << name;
  }
}

// --model auto never evaluates such a model, even with a budget nothing meets.
TEST(LightCover, AutoNeverChoosesAModelTheLightsCannotSupport) {
  const auto data =
      SynthData({.material = "plastic", .lights = "dome:12", .size = 16, .noise = 0.01});
  SceneSpec scene;
  scene.error_budget = 1e-6;  // unreachable: auto takes the lowest-error candidate
  SelectOptions o;
  o.max_coarser_levels = 0;
  auto sel = SelectModel(data.stack, scene, o);
  ASSERT_TRUE(sel.ok()) << sel.status().ToString();
  EXPECT_NE(sel->method, "hsh3");
  bool seen = false;
  for (const Candidate& c : sel->candidates)
    if (c.method == "hsh3") {
      seen = true;
      EXPECT_FALSE(c.evaluated);
      EXPECT_EQ(c.note.rfind("overfit risk:", 0), 0u) << c.note << " | " << sel->reason;
    }
  EXPECT_TRUE(seen);
}

}  // namespace
}  // namespace matfit::fit
