// Errors for API clients (issue #21): everything checkable is refused before the 202 with a 422
// that names the file or job field, the job fields the messages mention exist (layout,
// color_space), and no response shows a server path or a command-line flag.
#include <regex>

#include "server/api_wording.h"
#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

class ApiErrorsTest : public ServerTest {
 protected:
  // A lights-txt dataset folder tmp_/sets/NAME/obj (images obj.N.png, lights.txt).
  fs::path Dataset(const std::string& name, const std::string& lights = "dome:12", int bits = 16) {
    synth::SynthOptions so;
    so.material = "plaster", so.lights = lights, so.size = 8, so.bits = bits;
    so.layout = Layout::kLightsTxt;
    auto r = synth::Synthesize(so);
    EXPECT_TRUE(r.ok()) << r.status().message();
    const fs::path dir = tmp_ / "sets" / name / "obj";
    EXPECT_TRUE(synth::WriteSynthDataset(*r, so, dir.string(), false).ok());
    fs::remove_all(dir / "truth");
    return dir;
  }
  std::string Zip(const fs::path& dir) {
    const std::string out = (dir.parent_path() / "upload.zip").string();
    ArchiveWriter w(out, ArchiveWriter::Format::kZip);
    w.Folder(dir.string(), "obj");
    return out;
  }
  // Every response body must be free of server paths and CLI flags.
  void ExpectClean(const std::string& body) {
    bodies_.push_back(body);
    EXPECT_EQ(body.find(opts_.data_dir), std::string::npos) << body;
    EXPECT_EQ(body.find(tmp_.string()), std::string::npos) << body;
    EXPECT_EQ(body.find(".partial"), std::string::npos) << body;
    EXPECT_EQ(body.find("/tmp/"), std::string::npos) << body;
    EXPECT_FALSE(std::regex_search(body, std::regex("(^|[^a-z-])--[a-z]"))) << body;
  }
  json Expect(const httplib::Result& r, int status, const std::string& field) {
    EXPECT_TRUE(r);
    if (!r) return {};
    EXPECT_EQ(r->status, status) << r->body;
    ExpectClean(r->body);
    const json j = json::parse(r->body, nullptr, false);
    if (status >= 400) {
      EXPECT_EQ(j["error"].value("field", ""), field) << r->body;
    }
    return j;
  }
  std::string Message(const json& j) { return j["error"].value("message", ""); }
  std::vector<std::string> bodies_;
};

TEST_F(ApiErrorsTest, WrongImageSizeIsRefusedAtSubmissionNamingTheFileAndBothSizes) {
  Start();
  const fs::path d = Dataset("size");
  ASSERT_TRUE(WriteImage((d / "obj.3.png").string(), Image(6, 6, 3, 0.5f),
                         {PixelFormat::kUint16, TransferFunction::kLinear})
                  .ok());
  const json j = Expect(Upload(Zip(d), {{"model", "lambert"}}), 422, "file");
  EXPECT_NE(Message(j).find("'obj.3.png' is 6x6"), std::string::npos) << Message(j);
  EXPECT_NE(Message(j).find("8x8"), std::string::npos) << Message(j);
  ExpectDataClean(0);
}

TEST_F(ApiErrorsTest, LightCountMismatchIsRefusedAtSubmission) {
  Start();
  const fs::path d = Dataset("count");
  std::string lights = Slurp(d / "lights.txt");  // "12\n" + 12 lines → "11\n" + 11 lines
  lights = "11\n" + lights.substr(lights.find('\n') + 1);
  lights = lights.substr(0, lights.rfind('\n', lights.size() - 2) + 1);
  std::ofstream(d / "lights.txt") << lights;
  const json j = Expect(Upload(Zip(d), {{"model", "lambert"}}), 422, "file");
  EXPECT_NE(Message(j).find("'lights.txt' lists 11 lights but the folder has numbered images "
                            "obj.0 to obj.11: 12 image(s)"),
            std::string::npos)
      << Message(j);
  ExpectDataClean(0);
}

TEST_F(ApiErrorsTest, TwoLayoutsAreRefusedNamingBothAndTheLayoutFieldChoosesOne) {
  Start();
  const fs::path d = Dataset("two");
  std::string lp = "12\n";  // an .lp over the same images: evidence for lp too
  for (int i = 0; i < 12; ++i) lp += "obj." + std::to_string(i) + ".png 0 0 1\n";
  std::ofstream(d / "lights.lp") << lp;
  const std::string zip = Zip(d);
  const json j = Expect(Upload(zip, {{"model", "lambert"}}), 422, "layout");
  const std::string m = Message(j);
  EXPECT_NE(m.find("2 layouts: lp (one .lp light file (lights.lp)) and lights-txt"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("set the job field \"layout\" to lp or to lights-txt"), std::string::npos) << m;
  const json ok = Expect(Upload(zip, {{"model", "lambert"}, {"layout", "lights-txt"}}), 202, "");
  const json done = WaitFor(ok.value("id", ""), Finished);
  EXPECT_EQ(done.value("state", ""), "succeeded") << done.dump();
  EXPECT_EQ(done["options"].value("layout", ""), "lights-txt");
  ExpectClean(done.dump());
}

TEST_F(ApiErrorsTest, BadFieldValuesNameTheFieldAndTheChoices) {
  Start();
  const std::string zip = Zip(Dataset("fields"));
  std::string m = Message(Expect(Upload(zip, {{"layout", "psd"}}), 400, "layout"));
  EXPECT_NE(m.find("must be one of auto, bonn, utia, lp, diligent, lights-txt, got 'psd'"),
            std::string::npos)
      << m;
  m = Message(Expect(Upload(zip, {{"color_space", "gamma"}}), 400, "color_space"));
  EXPECT_NE(m.find("must be auto, srgb or linear, got 'gamma'"), std::string::npos) << m;
  m = Message(Expect(Upload(zip, {{"mode", "leaf"}, {"layout", "lp"}}), 400, "layout"));
  EXPECT_NE(m.find("does not apply to mode=leaf"), std::string::npos) << m;
  ExpectDataClean(0);
}

TEST_F(ApiErrorsTest, HoldoutAndAutoAreCheckedAgainstTheImageCountBeforeTheJob) {
  Start();
  const std::string zip = Zip(Dataset("count12"));
  std::string m = Message(Expect(Upload(zip, {{"holdout", "50"}}), 422, "holdout"));
  EXPECT_NE(m.find("50 folds need at least as many images, the dataset has 12"), std::string::npos)
      << m;
  const fs::path two = Dataset("two-images");
  for (int i = 2; i < 12; ++i) fs::remove(two / ("obj." + std::to_string(i) + ".png"));
  std::string lights = Slurp(two / "lights.txt");
  std::istringstream in(lights);
  std::string line, kept = "2\n";
  std::getline(in, line);
  for (int i = 0; i < 2 && std::getline(in, line); ++i) kept += line + "\n";
  std::ofstream(two / "lights.txt") << kept;
  m = Message(Expect(Upload(Zip(two), {{"model", "auto"}}), 422, "model"));
  EXPECT_NE(m.find("needs at least 3 images, the dataset has 2"), std::string::npos) << m;
  ExpectDataClean(0);
}

// The colour-space field reaches the read: a gamma-encoded set read as linear warns in the job
// summary (in API words), and color_space=srgb reads it right.
TEST_F(ApiErrorsTest, ColorSpaceFieldIsUsedAndWarningsSpeakOfJobFields) {
  Start();
  const fs::path d = Dataset("gamma", "dome:24", 8);  // 8-bit sRGB-encoded PNGs…
  for (const auto& e : fs::directory_iterator(d)) {   // …rewritten as 16-bit, no metadata
    if (e.path().extension() != ".png") continue;
    ImageReadOptions raw;
    raw.color_space = ColorSpaceChoice::kLinear;  // the sRGB codes themselves
    auto img = ReadImage(e.path().string(), raw);
    ASSERT_TRUE(img.ok());
    ASSERT_TRUE(
        WriteImage(e.path().string(), *img, {PixelFormat::kUint16, TransferFunction::kLinear})
            .ok());
  }
  const std::string zip = Zip(d);
  auto summary_warnings = [&](const std::vector<std::pair<std::string, std::string>>& f) {
    const json r = Expect(Upload(zip, f), 202, "");
    const json done = WaitFor(r.value("id", ""), Finished);
    EXPECT_EQ(done.value("state", ""), "succeeded") << done.dump();
    ExpectClean(done.dump());
    std::string all;
    for (const auto& w : done["summary"]["warnings"]) all += w.get<std::string>() + "\n";
    return all;
  };
  // auto (the default) follows the stack's own tone curve and says how to keep the first reading.
  const std::string automatic = summary_warnings({{"model", "lambert"}});
  EXPECT_NE(automatic.find("tone-corrected:"), std::string::npos) << automatic;
  EXPECT_NE(automatic.find("set the job field \"color_space\" to linear"), std::string::npos)
      << automatic;
  const std::string linear = summary_warnings({{"model", "lambert"}, {"color_space", "linear"}});
  EXPECT_NE(linear.find("gamma-encoded:"), std::string::npos) << linear;
  EXPECT_NE(linear.find("job field \"color_space\": \"srgb\""), std::string::npos) << linear;
  const std::string srgb = summary_warnings({{"model", "lambert"}, {"color_space", "srgb"}});
  EXPECT_EQ(srgb.find("gamma-encoded:"), std::string::npos) << srgb;
  EXPECT_EQ(srgb.find("tone-corrected:"), std::string::npos) << srgb;
}

TEST(ApiWording, FlagsBecomeJobFieldsOrNamedSettings) {
  EXPECT_EQ(ApiWording("see docs/formats.md or pass --layout"),
            "see docs/formats.md or set the job field \"layout\"");
  EXPECT_EQ(ApiWording("pass --layout lp or --layout lights-txt to say which"),
            "set the job field \"layout\" to lp or to lights-txt to say which");
  EXPECT_EQ(ApiWording("re-read them as sRGB (--color-space srgb) or linearise them"),
            "re-read them as sRGB (job field \"color_space\": \"srgb\") or linearise them");
  EXPECT_EQ(ApiWording("if the camera wrote them otherwise, pass --color-space linear"),
            "if the camera wrote them otherwise, set the job field \"color_space\" to linear");
  EXPECT_EQ(ApiWording("--holdout must be 0 (off) or ≥ 2 folds"),
            "job field \"holdout\" must be 0 (off) or ≥ 2 folds");
  EXPECT_EQ(ApiWording("give --mm-per-pixel"), "give the 'mm-per-pixel' setting (not a job field)");
  EXPECT_EQ(ApiWording("a 2--3 range and x-- y"), "a 2--3 range and x-- y");
}

}  // namespace
}  // namespace matfit::server::testing_fixture
