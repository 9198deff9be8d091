// The inputs labs have (issue 20, item 3): `.lp` files with another machine's paths, lights.txt
// sets with any image naming or an explicit list, RGBA alpha as the mask, --crop, and light
// counts that do not match the images (an error, never a silent drop). Camera RAW:
// raw_read_test.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/image_io.h"
#include "core/material_maps.h"
#include "core/stack_ops.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::WriteText;

bool HasWarning(const LightStack& s, const std::string& code) {
  for (const auto& w : s.read_warnings)
    if (w.rfind(code + ":", 0) == 0) return true;
  return false;
}

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// ---- .lp paths -------------------------------------------------------------------------------

// Rewrites every image name of an .lp file with `rename(name)`.
void RewriteLp(const std::string& lp, std::string (*rename)(const std::string&)) {
  auto lines = ReadLines(lp);
  std::string out = lines[0] + "\n";
  for (size_t i = 1; i < lines.size(); ++i) {
    const size_t sp = lines[i].find(' ');
    out += rename(lines[i].substr(0, sp)) + lines[i].substr(sp) + "\n";
  }
  WriteText(lp, out);
}

std::string LpFile(const std::string& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".lp") return e.path().string();
  return {};
}

// One table serves an integer stack only when every file has the first one's depth and transfer
// function; otherwise the loader starts again and reads every file as linear float32, each
// with its own decoding (what ReadImage gives). Integer stacks decode straight into their
// planes (ReadImageInto), so a file that differs must leave nothing behind.
TEST(StackLoad, FilesOfAnotherDepthOrCurveAreReadAsLinearFloat) {
  struct Case {
    const char* what;
    int bits;                   // of the set
    ImageWriteOptions rewrite;  // of its sixth image
  };
  const Case cases[] = {
      {"one 16-bit file among 8-bit ones", 8, {PixelFormat::kUint16, TransferFunction::kLinear}},
      {"one sRGB file among linear 16-bit ones",
       16,
       {PixelFormat::kUint16, TransferFunction::kSrgb}},
  };
  for (const Case& c : cases) {
    TempDir tmp;
    testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp, c.bits);
    const std::string lp = LpFile(tmp / "rti");
    auto uniform = ReadDataset(lp);
    ASSERT_TRUE(uniform.ok()) << c.what;
    EXPECT_EQ(uniform->sample_type(), c.bits == 8 ? SampleType::kUint8 : SampleType::kUint16);
    const std::string odd = uniform->image_files[5];
    auto img = ReadImage(odd);
    ASSERT_TRUE(img.ok());
    ASSERT_TRUE(WriteImage(odd, *img, c.rewrite).ok());
    auto s = ReadDataset(lp);
    ASSERT_TRUE(s.ok()) << c.what << ": " << s.status().message();
    EXPECT_EQ(s->sample_type(), SampleType::kFloat32) << c.what;
    ASSERT_EQ(s->num_images(), uniform->num_images());
    for (int i = 0; i < s->num_images(); ++i) {
      auto want = ReadImage(s->image_files[size_t(i)]);
      ASSERT_TRUE(want.ok());
      for (int ch = 0; ch < s->channels(); ++ch)
        for (int64_t p = 0; p < s->plane_size(); ++p)
          ASSERT_EQ(s->Sample(i, ch, p), want->Plane(ch)[size_t(p)])
              << c.what << ", image " << i << ", channel " << ch << ", texel " << p;
    }
    EXPECT_EQ(s->probe, nullptr) << c.what;  // float stacks are diagnosed from their planes
  }
}

TEST(LpPaths, WindowsAbsolutePathsFallBackToTheBaseNameWithANote) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return "C:\\Users\\lab\\captures\\" + n; });
  auto s = ReadDataset(lp);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);
  EXPECT_TRUE(HasWarning(*s, "lp-path-fallback"));
  const std::string& w = s->read_warnings.back();
  EXPECT_NE(w.find("12 of 12 image paths"), std::string::npos) << w;
  EXPECT_NE(w.find("C:\\Users\\lab\\captures\\"), std::string::npos) << w;

  // UNC paths and forward-slash Windows paths too.
  RewriteLp(lp, [](const std::string& n) {
    const std::string leaf = n.substr(n.find_last_of("\\") + 1);
    return "\\\\server\\share\\" + leaf;
  });
  ASSERT_TRUE(ReadDataset(lp).ok());
  RewriteLp(lp,
            [](const std::string& n) { return "D:/rti/" + n.substr(n.find_last_of("\\") + 1); });
  ASSERT_TRUE(ReadDataset(lp).ok());
}

TEST(LpPaths, AbsolutePosixPathsOfAnotherMachineFallBack) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return "/home/someone/else/" + n; });
  auto s = ReadDataset(lp);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);
  EXPECT_TRUE(HasWarning(*s, "lp-path-fallback"));
}

TEST(LpPaths, RelativePathsThatExistAreReadWithoutANote) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  auto s = ReadDataset(LpFile(tmp / "rti"));
  ASSERT_TRUE(s.ok());
  EXPECT_FALSE(HasWarning(*s, "lp-path-fallback"));
}

TEST(LpPaths, RelativeBackslashPathsAreSubfolders) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  fs::create_directories(tmp / "rti/jpeg-exports");
  for (const auto& e : fs::directory_iterator(tmp / "rti"))
    if (e.path().extension() == ".png" && e.path().filename() != "mask.png")
      fs::rename(e.path(), tmp / "rti/jpeg-exports" / e.path().filename());
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return "jpeg-exports\\" + n; });
  auto s = ReadDataset(lp);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);
  EXPECT_FALSE(HasWarning(*s, "lp-path-fallback"));  // found as written
  // "a:1.png" is a file name, not a Windows drive.
  EXPECT_FALSE(IsForeignPath("a:1.png"));
  EXPECT_TRUE(IsForeignPath("a:\\1.png"));
  EXPECT_TRUE(IsForeignPath("\\\\host\\share\\1.png"));
  EXPECT_EQ(ForeignBaseName("D:/rti/x 1.png"), "x 1.png");
}

TEST(LpPaths, AMissingImageNamesBothPlacesLookedIn) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return "C:\\captures\\missing_" + n; });
  auto s = ReadDataset(lp);
  ASSERT_FALSE(s.ok());
  const std::string& m = s.status().message();
  EXPECT_NE(m.find("C:\\captures\\missing_"), std::string::npos) << m;
  EXPECT_NE(m.find("nor as '" + (tmp / "rti") + "/missing_"), std::string::npos) << m;
  EXPECT_NE(m.find(":2:"), std::string::npos) << m;  // the line
}

TEST(LpPaths, AConfinedDatasetNeverReadsAnAbsolutePathOutsideIt) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "rti", Layout::kLp);
  // The .lp names images of the same name in another folder that exists: a server dataset must
  // not read them (nor learn they exist); it reads the ones in the dataset.
  fs::create_directories(tmp / "outside");
  for (const auto& e : fs::directory_iterator(tmp / "rti"))
    if (e.path().extension() == ".png")
      fs::copy_file(e.path(), tmp / "outside" / e.path().filename());
  static std::string outside;
  outside = tmp / "outside/";
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return outside + n; });
  ReadOptions o;
  o.confine_to = tmp / "rti";
  auto s = ReadDataset(lp, o);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  for (const auto& f : s->image_files) EXPECT_EQ(f.find("/outside/"), std::string::npos) << f;
  EXPECT_TRUE(HasWarning(*s, "lp-path-fallback"));
  // A relative name leading out of the folder is not looked at either.
  RewriteLp(lp,
            [](const std::string& n) { return "../outside/" + n.substr(n.find_last_of('/') + 1); });
  auto rel = ReadDataset(lp, o);
  ASSERT_TRUE(rel.ok()) << rel.status().ToString();
  for (const auto& f : rel->image_files) EXPECT_EQ(f.find("/outside/"), std::string::npos) << f;
  EXPECT_TRUE(HasWarning(*rel, "lp-path-fallback"));
  RewriteLp(lp, [](const std::string& n) { return outside + n.substr(n.find_last_of('/') + 1); });
  // Not confined (the CLI), the absolute path as written is the user's own file: it is read.
  auto cli = ReadDataset(lp);
  ASSERT_TRUE(cli.ok());
  EXPECT_NE(cli->image_files[0].find("/outside/"), std::string::npos);
  EXPECT_FALSE(HasWarning(*cli, "lp-path-fallback"));
}

// ---- lights.txt with any image naming ---------------------------------------------------------

TEST(LightsTxtNaming, ARenamedFolderStillLoadsByNaturalOrder) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  // Rename the images img1.png ... img12.png (natural order: img2 before img10) and the folder.
  for (int i = 0; i < 12; ++i)
    fs::rename(tmp / ("obj/obj." + std::to_string(i) + ".png"),
               tmp / ("obj/img" + std::to_string(i + 1) + ".png"));
  fs::rename(tmp / "obj", tmp / "renamed");
  std::string reason;
  auto layout = DetectLayout(tmp / "renamed", &reason);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  EXPECT_EQ(*layout, Layout::kLightsTxt);
  EXPECT_NE(reason.find("in light order by name"), std::string::npos) << reason;
  auto s = ReadDataset(tmp / "renamed");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);  // image i with light i
  EXPECT_NE(s->image_files[1].find("img2.png"), std::string::npos);
  EXPECT_NE(s->image_files[9].find("img10.png"), std::string::npos);
}

TEST(LightsTxtNaming, AMaskNamedFileIsTheMaskNotAnImage) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  for (int i = 0; i < 12; ++i)
    fs::rename(tmp / ("obj/obj." + std::to_string(i) + ".png"),
               tmp / ("obj/shot_" + std::to_string(i) + ".png"));
  Image mask(20, 16, 1);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 20; ++x) mask.At(0, y, x) = x < 10 ? 1.f : 0.f;
  ImageWriteOptions wo;
  wo.format = PixelFormat::kUint8;
  ASSERT_TRUE(WriteImage(tmp / "obj/Mask.png", mask, wo).ok());
  auto s = ReadDataset(tmp / "obj");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->num_images(), 12);
  ASSERT_TRUE(s->has_mask());
  EXPECT_EQ(s->MaskedTexels(), 10 * 16);
  EXPECT_NE(s->mask_source.find("Mask.png"), std::string::npos) << s->mask_source;
}

TEST(LightsTxtNaming, AnExplicitListGivesTheOrder) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  // Names whose sorted order is not the light order: z_0, y_1, x_2, ...; images.txt says it.
  std::string list;
  for (int i = 0; i < 12; ++i) {
    const std::string name = std::string(1, char('z' - i)) + "_" + std::to_string(i) + ".png";
    fs::rename(tmp / ("obj/obj." + std::to_string(i) + ".png"), tmp / ("obj/" + name));
    list += name + "\n";
  }
  WriteText(tmp / "obj/images.txt", list);
  auto s = ReadDataset(tmp / "obj");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);
  // A name the list gives that is not there: the line and the name.
  WriteText(tmp / "obj/images.txt", list + "extra.png\n");
  auto bad = ReadDataset(tmp / "obj");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("images.txt:13"), std::string::npos)
      << bad.status().message();
  EXPECT_NE(bad.status().message().find("'extra.png'"), std::string::npos);
  // A server dataset refuses a name leading out of its folder, naming it as written.
  fs::create_directories(tmp / "elsewhere");
  fs::copy_file(tmp / "obj/z_0.png", tmp / "elsewhere/z_0.png");
  WriteText(tmp / "obj/images.txt", "../elsewhere/z_0.png\n" + list.substr(list.find('\n') + 1));
  ReadOptions confined;
  confined.confine_to = tmp / "obj";
  auto out = ReadDataset(tmp / "obj", confined);
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.status().message().find("image '../elsewhere/z_0.png' not found in the dataset"),
            std::string::npos)
      << out.status().message();
  EXPECT_EQ(out.status().message().find(tmp.path()), std::string::npos) << out.status().message();
}

TEST(LightCount, MoreImagesThanLightsIsAnErrorInEveryNaming) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  auto lines = ReadLines(tmp / "obj/lights.txt");
  std::string eleven = "11\n";
  for (int i = 1; i <= 11; ++i) eleven += lines[i] + "\n";
  WriteText(tmp / "obj/lights.txt", eleven);
  auto numbered = ReadDataset(tmp / "obj");
  ASSERT_FALSE(numbered.ok());
  EXPECT_NE(numbered.status().message().find("lists 11 lights but the folder has numbered images "
                                             "obj.0 to obj.11: 12 image(s)"),
            std::string::npos)
      << numbered.status().message();
  for (int i = 0; i < 12; ++i)
    fs::rename(tmp / ("obj/obj." + std::to_string(i) + ".png"),
               tmp / ("obj/p" + std::to_string(i) + ".png"));
  auto listed = ReadDataset(tmp / "obj");
  ASSERT_FALSE(listed.ok());
  EXPECT_NE(listed.status().message().find("lists 11 lights but the folder has 12 image(s)"),
            std::string::npos)
      << listed.status().message();
  // Fewer images than lights: the first missing numbered image is named.
  TempDir t2;
  testing::WriteSynthSet(t2.path(), "obj", Layout::kLightsTxt);
  fs::remove(t2 / "obj/obj.11.png");
  auto missing = ReadDataset(t2 / "obj");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("image 11 of"), std::string::npos)
      << missing.status().message();
}

// ---- alpha as the mask -----------------------------------------------------------------------

// Rewrites every PNG of the numbered set as RGBA with alpha(x, y) from `alpha`.
void AddAlpha(const std::string& dir, int n, float (*alpha)(int x, int y, int image)) {
  for (int i = 0; i < n; ++i) {
    const std::string f = dir + "/obj." + std::to_string(i) + ".png";
    ImageReadOptions ro;
    ro.color_space = ColorSpaceChoice::kLinear;
    auto img = ReadImage(f, ro);
    ASSERT_TRUE(img.ok());
    Image rgba(img->width(), img->height(), 4);
    for (int y = 0; y < img->height(); ++y)
      for (int x = 0; x < img->width(); ++x) {
        for (int c = 0; c < 3; ++c) rgba.At(c, y, x) = img->At(c, y, x);
        rgba.At(3, y, x) = alpha(x, y, i);
      }
    ImageWriteOptions wo;
    wo.format = PixelFormat::kUint16;
    ASSERT_TRUE(WriteImage(f, rgba, wo).ok());
  }
}

TEST(AlphaMask, TheAlphaChannelIsTheMask) {
  TempDir tmp;
  const LightStack truth = testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  // Mostly opaque (0.75) in a disc that every image shares, except that image 3 also cuts the
  // top row; a faint 0.25 outside it.
  AddAlpha(tmp / "obj", 12, [](int x, int y, int i) {
    const float dx = x - 9.5f, dy = y - 7.5f;
    return (dx * dx + dy * dy < 36 && !(i == 3 && y == 2)) ? 0.75f : 0.25f;
  });
  auto s = ReadDataset(tmp / "obj");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  ASSERT_TRUE(s->has_mask());
  int64_t expect = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 20; ++x) {
      const float dx = x - 9.5f, dy = y - 7.5f;
      const bool in = dx * dx + dy * dy < 36 && y != 2;
      expect += in;
      EXPECT_EQ(s->mask[y * 20 + x], in ? 1 : 0) << x << "," << y;
    }
  EXPECT_EQ(s->MaskedTexels(), expect);
  EXPECT_EQ(s->mask_source, "alpha channel (12 of 12 images)");
  EXPECT_FALSE(HasWarning(*s, "alpha-dropped"));
  // The colours are read as stored, not multiplied by alpha.
  double worst = 0;
  for (int i = 0; i < 12; ++i)
    for (int c = 0; c < 3; ++c)
      for (int64_t p = 0; p < 20 * 16; ++p)
        worst = std::max(worst, double(std::abs(s->Sample(i, c, p) - truth.Sample(i, c, p))));
  EXPECT_LT(worst, 1e-4);
}

TEST(AlphaMask, OpaqueAlphaIsNoMaskAndTransparentEverywhereIsAnError) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  AddAlpha(tmp / "obj", 12, [](int, int, int) { return 1.f; });
  auto s = ReadDataset(tmp / "obj");
  ASSERT_TRUE(s.ok());
  EXPECT_FALSE(s->has_mask());
  EXPECT_NE(s->mask_source.find("opaque everywhere"), std::string::npos) << s->mask_source;
  AddAlpha(tmp / "obj", 12, [](int, int, int) { return 0.f; });
  auto t = ReadDataset(tmp / "obj");
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.status().message().find("transparent at every pixel"), std::string::npos)
      << t.status().message();
}

TEST(AlphaMask, AMaskFileWinsOverAlphaAndSaysSo) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  AddAlpha(tmp / "obj", 12, [](int x, int, int) { return x < 5 ? 0.f : 1.f; });
  Image mask(20, 16, 1);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 20; ++x) mask.At(0, y, x) = y < 8 ? 1.f : 0.f;
  ImageWriteOptions wo;
  wo.format = PixelFormat::kUint8;
  ASSERT_TRUE(WriteImage(tmp / "obj/obj.mask.png", mask, wo).ok());
  auto s = ReadDataset(tmp / "obj");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->MaskedTexels(), 20 * 8);
  EXPECT_TRUE(HasWarning(*s, "alpha-dropped"));
  EXPECT_NE(s->mask_source.find("obj.mask.png"), std::string::npos);
}

// ---- --crop ----------------------------------------------------------------------------------

TEST(Crop, ReadsExactlyTheRegionOfEveryImageAndMask) {
  TempDir tmp;
  for (Layout layout : {Layout::kLightsTxt, Layout::kLp, Layout::kDiligent}) {
    for (int bits : {8, 16}) {
      const std::string name = std::string(LayoutName(layout)) + std::to_string(bits);
      testing::WriteSynthSet(tmp.path(), name, layout, bits);
      const std::string dir = tmp / name;
      Image mask(20, 16, 1);
      for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 20; ++x) mask.At(0, y, x) = (x + y) % 3 ? 1.f : 0.f;
      ImageWriteOptions wo;
      wo.format = PixelFormat::kUint8;
      const std::string mask_file =
          layout == Layout::kLightsTxt ? dir + "/" + name + ".mask.png" : dir + "/mask.png";
      ASSERT_TRUE(WriteImage(mask_file, mask, wo).ok());
      auto whole = ReadDataset(dir);
      ASSERT_TRUE(whole.ok()) << name << ": " << whole.status().ToString();
      ReadOptions o;
      o.crop = CropRect{3, 5, 11, 7};
      auto part = ReadDataset(dir, o);
      ASSERT_TRUE(part.ok()) << name << ": " << part.status().ToString();
      auto expect = CropStack(*whole, 3, 5, 11, 7);
      ASSERT_TRUE(expect.ok());
      ASSERT_EQ(part->width(), 11);
      ASSERT_EQ(part->height(), 7);
      EXPECT_EQ(part->sample_type(), whole->sample_type()) << name;
      EXPECT_EQ(testing::MaxAbsDiff(*part, *expect), 0.0) << name;
      EXPECT_EQ(part->mask, expect->mask) << name;
      EXPECT_EQ(part->source_width, 20);
      EXPECT_EQ(part->source_height, 16);
      EXPECT_EQ(part->crop_x, 3);
      EXPECT_EQ(part->crop_y, 5);
      EXPECT_TRUE(part->is_read_crop());
      // A mip of the region (--model auto) is not the region: its truth is not cut to it.
      auto mip = DownsampleStack(*part, 2);
      ASSERT_TRUE(mip.ok());
      EXPECT_FALSE(mip->is_read_crop());
      EXPECT_EQ(mip->crop_w, 11);  // the read region stays on record (report.json "crop")
      EXPECT_FALSE(whole->is_read_crop());
      // A band of the crop (a rank of a distributed fit): rows 2..4 of the region.
      o.row0 = 2, o.rows = 3;
      auto band = ReadDataset(dir, o);
      ASSERT_TRUE(band.ok()) << band.status().ToString();
      auto expect_band = CropStack(*whole, 3, 7, 11, 3);
      EXPECT_EQ(testing::MaxAbsDiff(*band, *expect_band), 0.0) << name;
      EXPECT_EQ(band->full_height(), 7);
    }
  }
}

TEST(Crop, ARegionOutsideTheImagesIsAnErrorNamingIt) {
  TempDir tmp;
  testing::WriteSynthSet(tmp.path(), "obj", Layout::kLightsTxt);
  ReadOptions o;
  o.crop = CropRect{10, 0, 11, 16};  // one column too wide
  auto s = ReadDataset(tmp / "obj", o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("--crop 10,0,11,16"), std::string::npos)
      << s.status().message();
  EXPECT_NE(s.status().message().find("20x16 images"), std::string::npos);
  o.headers_only = true;  // the server's submission check refuses it too
  EXPECT_FALSE(ReadDataset(tmp / "obj", o).ok());
}

TEST(Crop, MapsOfAnotherSizeAreDroppedNotReadPastTheirEnd) {
  MaterialMaps m;
  m.width = 8, m.height = 6;
  m.normal = Image(8, 6, 3, 0.5f);
  m.specular = Image(1, 1, 1, 0.3f);   // a malformed truth map
  m.roughness = Image(8, 3, 1, 0.2f);  // right width, wrong height
  const MaterialMaps c = CropMaps(m, 2, 1, 5, 4);
  EXPECT_EQ(c.normal.width(), 5);
  EXPECT_EQ(c.normal.height(), 4);
  EXPECT_TRUE(c.specular.empty());
  EXPECT_TRUE(c.roughness.empty());
}

TEST(Crop, ParsesXYWidthHeight) {
  CropRect c;
  ASSERT_TRUE(ParseCrop("3,5,11,7", &c));
  EXPECT_EQ(c.x, 3);
  EXPECT_EQ(c.h, 7);
  for (const char* bad : {"", "3,5,11", "3,5,11,7,1", "3,5,0,7", "-1,5,11,7", "a,5,11,7",
                          "3,5,11,7 ", "3,,11,7", "1,1,9999999999,1"})
    EXPECT_FALSE(ParseCrop(bad, &c)) << bad;
}

}  // namespace
}  // namespace matfit
