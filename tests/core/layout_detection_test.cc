// Layout detection (core/dataset/dataset.cc DetectLayout): evidence for one layout picks it; a
// folder with evidence for two is refused naming both, never guessed; --layout reads either.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/dataset/dataset.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

TEST(LayoutDetection, TwoLayoutsAreRefusedNamingBothAndEitherCanBeChosen) {
  testing::TempDir tmp;
  synth::SynthOptions so;
  so.material = "plaster", so.lights = "dome:8", so.size = 8, so.layout = Layout::kLightsTxt;
  auto r = synth::Synthesize(so);
  ASSERT_TRUE(r.ok());
  const std::string dir = tmp / "obj";
  ASSERT_TRUE(synth::WriteSynthDataset(*r, so, dir, false).ok());
  std::string reason;
  auto one = DetectLayout(dir, &reason);
  ASSERT_TRUE(one.ok()) << one.status().message();
  EXPECT_EQ(*one, Layout::kLightsTxt);
  // Add an .lp over the same images: now two layouts have evidence.
  {
    std::ofstream lp(dir + "/set.lp");
    lp << "8\n";
    for (int i = 0; i < 8; ++i) lp << "obj." << i << ".png 0 0.1 1\n";
  }
  auto two = DetectLayout(dir, &reason);
  ASSERT_FALSE(two.ok());
  EXPECT_EQ(two.status().code(), StatusCode::kDataError);
  const std::string& m = two.status().message();
  EXPECT_NE(m.find("holds the files of 2 layouts: lp (one .lp light file (set.lp)) and lights-txt"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("pass --layout lp or --layout lights-txt"), std::string::npos) << m;
  EXPECT_FALSE(ReadDataset(dir).ok());
  for (Layout l : {Layout::kLp, Layout::kLightsTxt}) {
    ReadOptions o;
    o.layout = l;
    auto s = ReadDataset(dir, o);
    ASSERT_TRUE(s.ok()) << LayoutName(l) << ": " << s.status().message();
    EXPECT_EQ(s->num_images(), 8);
  }
}

}  // namespace
}  // namespace matfit
