// Malformed inputs: the documented error, naming the file (and line), and no crash.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::WriteText;

// A valid 4-light .lp dataset in dir (images 8×8).
void MakeLp(const std::string& dir, int lights = 4) {
  synth::SynthOptions o;
  o.lights = "ring:" + std::to_string(lights);
  o.size = 8;
  o.layout = Layout::kLp;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(WriteDataset(r->stack, {Layout::kLp, 16, "x"}, dir).ok());
}

void ExpectError(const StatusOr<LightStack>& r, StatusCode code,
                 std::initializer_list<const char*> parts) {
  ASSERT_FALSE(r.ok()) << "expected an error";
  EXPECT_EQ(r.status().code(), code) << r.status().ToString();
  for (const char* p : parts)
    EXPECT_NE(r.status().message().find(p), std::string::npos)
        << "message lacks '" << p << "': " << r.status().message();
}

TEST(Malformed, LpMissingImage) {
  TempDir tmp;
  MakeLp(tmp.path());
  fs::remove(tmp / "img_002.png");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kNotFound,
              {"lights.lp:4", "img_002.png", "not found"});
}

TEST(Malformed, LpWrongCount) {
  TempDir tmp;
  MakeLp(tmp.path());
  WriteText(tmp / "lights.lp",
            "5\nimg_000.png 0 0 1\nimg_001.png 0 0.5 0.8\nimg_002.png 0.5 0 0.8\nimg_003.png -0.5 "
            "0 0.8\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"lights.lp", "says 5 lights but 4"});
}

TEST(Malformed, LpNanDirection) {
  TempDir tmp;
  MakeLp(tmp.path());
  WriteText(tmp / "lights.lp",
            "4\nimg_000.png 0 0 1\nimg_001.png nan 0.5 0.8\nimg_002.png 0.5 0 0.8\nimg_003.png "
            "-0.5 0 0.8\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"lights.lp:3", "not three finite numbers"});
}

TEST(Malformed, LpZeroDirectionAndShortLine) {
  TempDir tmp;
  MakeLp(tmp.path());
  WriteText(
      tmp / "lights.lp",
      "4\nimg_000.png 0 0 1\nimg_001.png 0 0 0\nimg_002.png 0.5 0 0.8\nimg_003.png -0.5 0 0.8\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError, {"lights.lp:3", "zero vector"});
  WriteText(
      tmp / "lights.lp",
      "4\nimg_000.png 0 0 1\nimg_001.png 0 0\nimg_002.png 0.5 0 0.8\nimg_003.png -0.5 0 0.8\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"lights.lp:3", "expected 'file lx ly lz'"});
  WriteText(tmp / "lights.lp", "four\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError, {"lights.lp:1", "number of lights"});
}

TEST(Malformed, SizeMismatchNamesBothFiles) {
  TempDir tmp;
  MakeLp(tmp.path());
  ASSERT_TRUE(WriteImage(tmp / "img_003.png", Image(9, 8, 3, 0.5f), {}).ok());
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"img_003.png", "9x8", "img_000.png", "8x8", "same size"});
}

TEST(Malformed, TruncatedPngInAStack) {
  TempDir tmp;
  MakeLp(tmp.path());
  fs::resize_file(tmp / "img_001.png", fs::file_size(tmp / "img_001.png") / 2);
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"img_001.png", "truncated or corrupt"});
}

TEST(Malformed, EmptyFolderAndUnknownFolder) {
  TempDir tmp;
  fs::create_directories(tmp / "empty");
  ExpectError(ReadDataset(tmp / "empty"), StatusCode::kDataError,
              {"empty", "expected images and a light file"});
  fs::create_directories(tmp / "junk");
  WriteText(tmp / "junk/readme.txt", "hello");
  ExpectError(ReadDataset(tmp / "junk"), StatusCode::kDataError,
              {"cannot tell the layout", "--layout"});
  ExpectError(ReadDataset(tmp / "nowhere"), StatusCode::kNotFound, {"nowhere", "does not exist"});
}

TEST(Malformed, SeveralLpFilesAskWhichOne) {
  TempDir tmp;
  MakeLp(tmp.path());
  fs::copy_file(tmp / "lights.lp", tmp / "other.lp");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kInvalidArgument,
              {"several .lp files", "lights.lp", "other.lp"});
  EXPECT_TRUE(ReadDataset(tmp / "other.lp").ok());  // naming the file works
}

TEST(Malformed, DiligentCountMismatchAndBadIntensity) {
  TempDir tmp;
  synth::SynthOptions o;
  o.lights = "ring:4";
  o.size = 8;
  o.layout = Layout::kDiligent;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(WriteDataset(r->stack, {Layout::kDiligent, 16, "x"}, tmp.path()).ok());
  WriteText(tmp / "light_directions.txt", "0 0 1\n0 0.5 0.8\n0.5 0 0.8\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"light_directions.txt", "3 directions", "4 images"});
  WriteText(tmp / "light_directions.txt", "0 0 1\n0 0.5 0.8\n0.5 0 0.8\n-0.5 0 0.8\n");
  WriteText(tmp / "light_intensities.txt", "1 1 1\n1 1 1\n1 x 1\n1 1 1\n");
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError,
              {"light_intensities.txt:3", "three finite numbers"});
}

TEST(Malformed, LightsTxtMissingImage) {
  TempDir tmp;
  const std::string dir = tmp / "obj";
  fs::create_directories(dir);
  synth::SynthOptions o;
  o.lights = "ring:4";
  o.size = 8;
  o.layout = Layout::kLightsTxt;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(WriteDataset(r->stack, {Layout::kLightsTxt, 16, "obj"}, dir).ok());
  fs::remove(dir + "/obj.3.png");
  ExpectError(ReadDataset(dir, {Layout::kLightsTxt}), StatusCode::kNotFound, {"image 3", "obj.3"});
}

TEST(Malformed, BonnDuplicateAndNoMatchingNames) {
  TempDir tmp;
  fs::create_directories(tmp / "v");
  ASSERT_TRUE(
      WriteImage(tmp / "v/00000 tl000 pl000 tv000 pv000.png", Image(4, 4, 3, 0.5f), {}).ok());
  ASSERT_TRUE(
      WriteImage(tmp / "v/00001 tl000 pl000 tv000 pv000.png", Image(4, 4, 3, 0.5f), {}).ok());
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError, {"same light and view angles"});
  ExpectError(ReadDataset(tmp.path(), {Layout::kUtia}), StatusCode::kDataError,
              {"tl000_pl000_tv000_pv000"});
}

TEST(Malformed, OverlongNumbersInNamesAreNotParsed) {
  TempDir tmp;
  ASSERT_TRUE(
      WriteImage(tmp / "99999999999999999999 tl000 pl000 tv000 pv000.png", Image(4, 4, 3, 0.5f), {})
          .ok());
  ExpectError(ReadDataset(tmp.path()), StatusCode::kDataError, {"cannot tell the layout"});
  ExpectError(ReadDataset(tmp.path(), {Layout::kBonn}), StatusCode::kDataError, {"NNNNN tlAAA"});
}

TEST(Malformed, BinaryJunkLightFile) {
  TempDir tmp;
  std::string junk;
  for (int i = 0; i < 4096; ++i) junk += char((i * 7919) & 0xff);
  WriteText(tmp / "x.lp", junk);
  auto r = ReadDataset(tmp / "x.lp");
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("x.lp"), std::string::npos) << r.status().message();
  WriteText(tmp / "x.lp", "99999999999999999999\n");
  ExpectError(ReadDataset(tmp / "x.lp"), StatusCode::kDataError, {"x.lp:1"});
}

TEST(Malformed, BadViewOption) {
  ReadOptions o;
  o.view = ViewAngles{95, 0};
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--view"), std::string::npos);
}

}  // namespace
}  // namespace matfit
