// The inputs labs have (issue 20, item 3): `.lp` files with another machine's paths, lights.txt
// sets with any image naming or an explicit list, RGBA alpha as the mask, --crop, camera RAW
// (DNG), and light counts that do not match the images (an error, never a silent drop).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/material_maps.h"
#include "core/stack_ops.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::WriteText;

// A 12-light 20x16 plaster set in `layout`, written to dir/name; returns the stack written.
LightStack WriteSet(const std::string& dir, const std::string& name, Layout layout, int bits = 16) {
  synth::SynthOptions o;
  o.material = "plaster";
  o.lights = "dome:12";
  o.size = 20;
  o.layout = layout;
  o.bits = bits;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  auto crop = CropStack(r->stack, 0, 0, 20, 16);  // non-square: rows and columns differ
  EXPECT_TRUE(crop.ok());
  DatasetWriteOptions wo;
  wo.layout = layout;
  wo.bits = bits;
  wo.object_name = name;
  const std::string out = dir + "/" + name;
  fs::create_directories(out);
  EXPECT_TRUE(WriteDataset(*crop, wo, out).ok());
  return std::move(*crop);
}

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

TEST(LpPaths, WindowsAbsolutePathsFallBackToTheBaseNameWithANote) {
  TempDir tmp;
  const LightStack truth = WriteSet(tmp.path(), "rti", Layout::kLp);
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
  const LightStack truth = WriteSet(tmp.path(), "rti", Layout::kLp);
  const std::string lp = LpFile(tmp / "rti");
  RewriteLp(lp, [](const std::string& n) { return "/home/someone/else/" + n; });
  auto s = ReadDataset(lp);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_LT(testing::MaxAbsDiff(*s, truth), 1e-4);
  EXPECT_TRUE(HasWarning(*s, "lp-path-fallback"));
}

TEST(LpPaths, RelativePathsThatExistAreReadWithoutANote) {
  TempDir tmp;
  WriteSet(tmp.path(), "rti", Layout::kLp);
  auto s = ReadDataset(LpFile(tmp / "rti"));
  ASSERT_TRUE(s.ok());
  EXPECT_FALSE(HasWarning(*s, "lp-path-fallback"));
}

TEST(LpPaths, RelativeBackslashPathsAreSubfolders) {
  TempDir tmp;
  const LightStack truth = WriteSet(tmp.path(), "rti", Layout::kLp);
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
  WriteSet(tmp.path(), "rti", Layout::kLp);
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
  const LightStack truth = WriteSet(tmp.path(), "rti", Layout::kLp);
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
  const LightStack truth = WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  const LightStack truth = WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  WriteSet(t2.path(), "obj", Layout::kLightsTxt);
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
  const LightStack truth = WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
  WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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
      WriteSet(tmp.path(), name, layout, bits);
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
  WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
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

// ---- camera RAW (DNG) ------------------------------------------------------------------------

// A minimal uncompressed LinearRaw DNG (TIFF/EP, DNG 1.4): 16-bit RGB `codes` (w × h × 3,
// interleaved) from a camera whose native space is linear sRGB (ColorMatrix1 = XYZ→sRGB) and
// the as-shot white balance `neutral` (the camera's response to white, per channel).
void WriteLinearDng(const std::string& path, int w, int h, const std::vector<uint16_t>& codes,
                    const double neutral[3]) {
  struct Entry {
    uint16_t tag, type;
    uint32_t count;
    std::vector<uint8_t> value;
  };
  auto le = [](std::vector<uint8_t>* v, uint64_t x, int bytes) {
    for (int i = 0; i < bytes; ++i) v->push_back(uint8_t(x >> (8 * i)));
  };
  std::vector<Entry> e;
  auto add = [&](uint16_t tag, uint16_t type, std::vector<int64_t> vals, int bytes) {
    Entry en{tag, type, uint32_t(vals.size()), {}};
    for (int64_t v : vals) le(&en.value, uint64_t(v), bytes);
    if (type == 5 || type == 10) en.count /= 2;  // (numerator, denominator) pairs
    e.push_back(en);
  };
  auto ascii = [&](uint16_t tag, const std::string& s) {
    Entry en{tag, 2, uint32_t(s.size() + 1), std::vector<uint8_t>(s.begin(), s.end())};
    en.value.push_back(0);
    e.push_back(en);
  };
  const uint32_t pixel_bytes = uint32_t(codes.size() * 2);
  add(254, 4, {0}, 4);
  add(256, 4, {w}, 4);
  add(257, 4, {h}, 4);
  add(258, 3, {16, 16, 16}, 2);
  add(259, 3, {1}, 2);
  add(262, 3, {34892}, 2);  // LinearRaw
  ascii(271, "matfit");
  ascii(272, "test camera");
  add(273, 4, {0}, 4);  // strip offset, patched below
  add(274, 3, {1}, 2);
  add(277, 3, {3}, 2);
  add(278, 4, {h}, 4);
  add(279, 4, {pixel_bytes}, 4);
  add(284, 3, {1}, 2);
  add(50706, 1, {1, 4, 0, 0}, 1);  // DNGVersion
  ascii(50708, "matfit test camera");
  add(50714, 4, {0}, 4);      // BlackLevel
  add(50717, 4, {65535}, 4);  // WhiteLevel
  const double xyz_to_srgb[9] = {3.2404542, -1.5371385, -0.4985314, -0.9692660, 1.8760108,
                                 0.0415560, 0.0556434,  -0.2040259, 1.0572252};
  std::vector<int64_t> cm;
  for (double v : xyz_to_srgb)
    cm.push_back(uint32_t(int32_t(std::lround(v * 10000)))), cm.push_back(10000);
  add(50721, 10, cm, 4);  // ColorMatrix1
  std::vector<int64_t> as_shot;
  for (int c = 0; c < 3; ++c)
    as_shot.push_back(std::lround(neutral[c] * 10000)), as_shot.push_back(10000);
  add(50728, 5, as_shot, 4);  // AsShotNeutral
  add(50778, 3, {21}, 2);     // CalibrationIlluminant1 = D65
  std::sort(e.begin(), e.end(), [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
  const uint32_t ifd = 8, extra0 = ifd + 2 + 12 * uint32_t(e.size()) + 4;
  std::vector<uint8_t> extra, dir;
  std::vector<uint32_t> offsets(e.size(), 0);
  for (size_t i = 0; i < e.size(); ++i)
    if (e[i].value.size() > 4) {
      offsets[i] = extra0 + uint32_t(extra.size());
      extra.insert(extra.end(), e[i].value.begin(), e[i].value.end());
      if (extra.size() % 2) extra.push_back(0);
    }
  const uint32_t data = extra0 + uint32_t(extra.size());
  le(&dir, e.size(), 2);
  for (size_t i = 0; i < e.size(); ++i) {
    le(&dir, e[i].tag, 2);
    le(&dir, e[i].type, 2);
    le(&dir, e[i].count, 4);
    if (e[i].tag == 273) {
      le(&dir, data, 4);
    } else if (offsets[i]) {
      le(&dir, offsets[i], 4);
    } else {
      std::vector<uint8_t> v = e[i].value;
      v.resize(4, 0);
      dir.insert(dir.end(), v.begin(), v.end());
    }
  }
  le(&dir, 0, 4);
  std::ofstream out(path, std::ios::binary);
  const uint8_t header[8] = {'I', 'I', 42, 0, 8, 0, 0, 0};
  out.write(reinterpret_cast<const char*>(header), 8);
  out.write(reinterpret_cast<const char*>(dir.data()), std::streamsize(dir.size()));
  out.write(reinterpret_cast<const char*>(extra.data()), std::streamsize(extra.size()));
  out.write(reinterpret_cast<const char*>(codes.data()), std::streamsize(pixel_bytes));
}

TEST(CameraRaw, DngReadsLinearWithTheCamerasWhiteBalance) {
  TempDir tmp;
  const int w = 64, h = 32;  // libraw leaves images under 32 rows unbalanced
  std::vector<uint16_t> codes(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) codes[(size_t(y) * w + x) * 3 + c] = uint16_t(x * 800 + 1000);
  const double neutral_white[3] = {1, 1, 1};
  WriteLinearDng(tmp / "grey.dng", w, h, codes, neutral_white);
  ImageFileInfo info;
  auto img = ReadImage(tmp / "grey.dng", {}, &info);
  ASSERT_TRUE(img.ok()) << img.status().ToString();
  ASSERT_EQ(img->width(), w);
  ASSERT_EQ(img->channels(), 3);
  EXPECT_EQ(info.encoding.transfer, TransferFunction::kLinear) << info.encoding_reason;
  // Linear: value ∝ code (no gamma, no automatic brightening): v(x) / code(x) is one constant.
  const double k = img->At(1, 4, 20) / codes[(4 * w + 20) * 3 + 1];
  for (int x = 4; x < w; x += 7)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(img->At(c, 4, x) / codes[(4 * w + x) * 3 + c], k, 0.02 * k) << x << " " << c;
  // The camera's white balance: a camera that sees white as (0.5, 1, 1) has its red doubled.
  const double neutral_red[3] = {0.5, 1, 1};
  WriteLinearDng(tmp / "red.dng", w, h, codes, neutral_red);
  auto red = ReadImage(tmp / "red.dng");
  ASSERT_TRUE(red.ok()) << red.status().ToString();
  const double ratio = red->At(0, 4, 20) / red->At(1, 4, 20);
  EXPECT_NEAR(ratio, 2.0, 0.1);
}

TEST(CameraRaw, ALightsTxtSetOfDngFilesLoads) {
  TempDir tmp;
  const LightStack truth = WriteSet(tmp.path(), "obj", Layout::kLightsTxt);
  fs::create_directories(tmp / "raw");
  fs::copy_file(tmp / "obj/lights.txt", tmp / "raw/lights.txt");
  const double white[3] = {1, 1, 1};
  for (int i = 0; i < 12; ++i) {
    std::vector<uint16_t> codes(20 * 16 * 3);
    for (int p = 0; p < 20 * 16; ++p)
      for (int c = 0; c < 3; ++c)
        codes[p * 3 + c] = uint16_t(std::lround(truth.Sample(i, c, p) * 65535));
    WriteLinearDng(tmp / ("raw/IMG_" + std::to_string(100 + i) + ".dng"), 20, 16, codes, white);
  }
  auto s = ReadDataset(tmp / "raw");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->num_images(), 12);
  // Same images up to the camera pipeline's scale: the ratio to the truth is one constant.
  double num = 0, den = 0;
  for (int i = 0; i < 12; ++i)
    for (int64_t p = 0; p < 20 * 16; ++p) num += s->Sample(i, 1, p), den += truth.Sample(i, 1, p);
  const double k = num / den;
  double worst = 0;
  for (int i = 0; i < 12; ++i)
    for (int64_t p = 0; p < 20 * 16; ++p)
      worst = std::max(worst, std::abs(s->Sample(i, 1, p) - k * truth.Sample(i, 1, p)));
  EXPECT_LT(worst, 0.01 * k) << "scale " << k;
}

}  // namespace
}  // namespace matfit
