// Multi-view BTFs (issue 17): rendering every view rectified (parallax, masking, shadows), writing
// them in the Bonn and UTIA layouts and reading every view back (`--view all`).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include <cmath>
#include <filesystem>

#include "core/dataset/band_cache.h"
#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/model/model.h"
#include "core/synth/materials.h"
#include "core/synth/render_views.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// A tilted plane h = a·x + b (texel units) with a uniform Lambertian albedo.
MaterialMaps TiltedPlane(int size, double a, double b) {
  MaterialMaps m;
  m.model = ShadingModel::kLambert;
  m.width = m.height = size;
  m.height_map = Image(size, size, 1);
  m.albedo = Image(size, size, 3, 0.5f);
  m.mask = Image(size, size, 1, 1.0f);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) m.height_map.At(0, y, x) = float(a * x + b);
  m.normal = synth::NormalsFromHeight(m.height_map);
  return m;
}

// Synthesises `o` into `dir` and reads it back with `ro`.
StatusOr<LightStack> WriteAndRead(const synth::SynthOptions& o, const std::string& dir,
                                  const ReadOptions& ro) {
  auto r = synth::Synthesize(o);
  if (!r.ok()) return r.status();
  MATFIT_RETURN_IF_ERROR(synth::WriteSynthDataset(*r, o, dir, false));
  return ReadDataset(dir, ro);
}

TEST(MultiView, TheFrontalViewSeesEveryTexelWhereItIs) {
  auto maps = synth::MakeMaterial("lacquer", 24, 3);
  ASSERT_TRUE(maps.ok());
  const synth::ViewWarp w = synth::WarpToView(*maps, {0, 0, 1});
  for (int64_t p = 0; p < 24 * 24; ++p) {
    ASSERT_EQ(w.col[p], float(p % 24));
    ASSERT_EQ(w.row[p], float(p / 24));
    ASSERT_EQ(w.maps.roughness.data()[p], maps->roughness.data()[p]);
    ASSERT_NEAR(w.maps.normal.Plane(2)[p], maps->normal.Plane(2)[p], 1e-6);
  }
}

TEST(MultiView, AnObliqueViewSeesThePointItsRayMeets) {
  // Plane h = 0.1 x + 2 seen from θv = 40° toward +x: the ray through (x, y, 0) rises s·v_z while
  // moving s·v_x, so it meets the plane where s v_z = 0.1 (x + s v_x) + 2, s = (0.1x + 2) /
  // (v_z − 0.1 v_x); rows do not move (v_y = 0).
  const MaterialMaps m = TiltedPlane(40, 0.1, 2.0);
  const double t = 40 * M_PI / 180;
  const Vec3 v(std::sin(t), 0, std::cos(t));
  const synth::ViewWarp w = synth::WarpToView(m, v);
  for (int y : {5, 20}) {
    for (int x : {0, 7, 13, 20}) {
      const int64_t p = int64_t(y) * 40 + x;
      const double s = (0.1 * x + 2) / (v.z - 0.1 * v.x);
      EXPECT_NEAR(w.col[p], x + s * v.x, 1e-3) << x;
      EXPECT_NEAR(w.row[p], y, 1e-6);
      EXPECT_NEAR(w.z[p], s * v.z, 1e-3);
    }
  }
  // The albedo is uniform, so the seen point's maps are the plane's.
  EXPECT_NEAR(w.maps.albedo.At(0, 5, 7), 0.5f, 1e-6);
}

TEST(MultiView, ABumpHidesWhatIsBehindItFromAGrazingView) {
  // A 6-texel-high wall across rows at x = 20 on a flat floor: from θv = 70° toward −x the camera
  // rays through floor texels just beyond the wall (x = 21…30) meet the wall first (masking).
  MaterialMaps m = TiltedPlane(48, 0, 0);
  for (int y = 0; y < 48; ++y)
    for (int x = 18; x <= 20; ++x) m.height_map.At(0, y, x) = 6;
  m.normal = synth::NormalsFromHeight(m.height_map);
  const double t = 70 * M_PI / 180;
  const synth::ViewWarp w = synth::WarpToView(m, {-std::sin(t), 0, std::cos(t)});
  for (int x = 21; x <= 22; ++x) EXPECT_GT(w.z[size_t(10 * 48 + x)], 1.0f) << x;  // on the wall
  EXPECT_NEAR(w.z[size_t(10 * 48 + 40)], 0.0f, 1e-3);  // far from it: the floor
  EXPECT_NEAR(w.col[size_t(10 * 48 + 40)], 40.0f, 1e-3);
}

TEST(MultiView, FresnelAndMaskingShowAcrossViewsOnly) {
  // lacquer under one light at 45°: the same texel brightens toward a grazing view on the mirror
  // side (Fresnel, the GGX lobe) — nothing one view could show.
  auto maps = synth::MakeMaterial("lacquer", 16, 1);
  ASSERT_TRUE(maps.ok());
  const double t = 45 * M_PI / 180;
  std::vector<LightSample> lights = {LightFromDirection({std::sin(t), 0, std::cos(t)})};
  std::vector<Vec3> views;
  for (double tv : {0.0, 30.0, 60.0, 75.0})
    views.push_back({-std::sin(tv * M_PI / 180), 0, std::cos(tv * M_PI / 180)});
  const LightStack s = synth::RenderViews(*maps, lights, views, false);
  ASSERT_EQ(s.num_images(), 4);
  ASSERT_TRUE(s.is_multi_view());
  EXPECT_EQ(ViewGroups(s).size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(s.lights()[size_t(i)].has_view);
    EXPECT_NEAR(s.lights()[size_t(i)].view_theta_deg,
                i == 0   ? 0
                : i == 1 ? 30
                : i == 2 ? 60
                         : 75,
                1e-9);
  }
  double mean[4] = {0, 0, 0, 0};
  for (int i = 0; i < 4; ++i)
    for (float v : s.Plane(i, 1)) mean[i] += v / 256.0;
  EXPECT_GT(mean[2], 1.5 * mean[0]);  // the mirror direction (45°) lies between 30° and 60°
  EXPECT_GT(mean[3], mean[0]);
}

TEST(MultiView, WritesAndReadsEveryViewInEveryLayoutThatGivesViews) {
  for (Layout layout : {Layout::kBonn, Layout::kUtia, Layout::kLp}) {
    // The .lp gives directions as written decimals (9 significant digits), the BTFs as angles.
    const double tol = layout == Layout::kLp ? 1e-7 : 1e-9;
    TempDir tmp;
    synth::SynthOptions o;
    o.material = "lacquer";
    o.lights = "bonn81";
    o.views = "dome:6";
    o.size = 12;
    o.layout = layout;
    o.bits = 32;
    auto r = synth::Synthesize(o);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_EQ(r->stack.num_images(), 6 * 81);
    const std::string dir = tmp / "btf";
    ASSERT_TRUE(synth::WriteSynthDataset(*r, o, dir, false).ok());
    if (layout == Layout::kBonn) {  // one folder per view
      int folders = 0;
      for (const auto& e : fs::directory_iterator(dir))
        folders += e.is_directory() && e.path().filename() != "truth";
      EXPECT_EQ(folders, 6);
    }
    ReadOptions ro;
    ro.all_views = true;
    auto back = ReadDataset(dir, ro);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(back->num_images(), 6 * 81);
    EXPECT_TRUE(back->is_multi_view());
    const auto groups = ViewGroups(*back);
    ASSERT_EQ(groups.size(), 6u);
    // Every written image is read back with its light, its view and its pixels (float EXR:
    // exact), wherever the reader placed it.
    for (int i = 0; i < r->stack.num_images(); ++i) {
      const LightSample& w = r->stack.lights()[size_t(i)];
      int found = -1;
      for (int k = 0; k < back->num_images() && found < 0; ++k) {
        const LightSample& b = back->lights()[size_t(k)];
        if (Length(b.direction - w.direction) < tol && Length(b.view - w.view) < tol) found = k;
      }
      ASSERT_GE(found, 0) << "image " << i << " not read back";
      EXPECT_EQ(back->Sample(found, 1, 37), r->stack.Plane(i, 1)[37]);
    }
    // The reference view is the most frontal one, and one view alone reads as before.
    EXPECT_NEAR(back->view_direction.z, back->ViewOf(groups[MostFrontalView(*back, groups)][0]).z,
                1e-12);
    auto one = ReadDataset(dir);
    ASSERT_TRUE(one.ok());
    EXPECT_EQ(one->num_images(), 81);
    EXPECT_FALSE(one->is_multi_view());
    EXPECT_NEAR(Length(one->view_direction - back->view_direction), 0, tol);
    // --view θ,φ: that view's images, seen from it.
    const LightSample& last = back->lights().back();
    ReadOptions pick;
    pick.view = ViewAngles{last.view_theta_deg, last.view_phi_deg};
    auto picked = ReadDataset(dir, pick);
    ASSERT_TRUE(picked.ok()) << picked.status().ToString();
    EXPECT_EQ(picked->num_images(), 81);
    EXPECT_NEAR(Length(picked->view_direction - last.view), 0, 1e-6);
  }
}

TEST(MultiView, TheBandCacheHoldsEveryImagesRowsAsReadInMemory) {
  for (int bits : {8, 16, 32}) {
    TempDir tmp;
    synth::SynthOptions o;
    o.material = "lacquer", o.lights = "bonn81", o.views = "dome:5", o.size = 20, o.bits = bits;
    ReadOptions ro;
    ro.all_views = true;
    auto whole = WriteAndRead(o, tmp / "btf", ro);
    ASSERT_TRUE(whole.ok()) << whole.status().ToString();
    ro.headers_only = true;
    auto shape = ReadDataset(tmp / "btf", ro);
    ASSERT_TRUE(shape.ok());
    ro.headers_only = false;
    // Bands of 3 rows (the last 2); decode chunks of 37 images at float size then 74 or 148 at
    // the native depth: a chunk boundary that moves after the first chunk.
    BandCacheOptions co;
    co.band_bytes = int64_t(405) * 3 * 20 * 3 * (bits / 8);
    co.dir = tmp.path();
    int64_t reported = 0;
    co.progress = [&](int64_t done, int64_t total) {
      EXPECT_EQ(total, 405);
      reported = done;
      return true;
    };
    auto cache = BandCache::Build(*shape, ro, co);
    ASSERT_TRUE(cache.ok()) << cache.status().ToString();
    EXPECT_EQ(reported, 405);
    ASSERT_EQ(cache->bands(), 7) << bits;
    EXPECT_EQ(cache->band_rows(6), 2);
    for (int b = 0; b < cache->bands(); ++b) {
      auto band = cache->Load(b);
      ASSERT_TRUE(band.ok());
      ASSERT_EQ(band->num_images(), 405);
      EXPECT_EQ(band->sample_type(), whole->sample_type());
      EXPECT_TRUE(band->is_multi_view());
      for (int i = 0; i < 405; ++i)
        for (int c = 0; c < 3; ++c)
          for (int y = 0; y < band->height(); ++y)
            for (int x = 0; x < 20; ++x)
              ASSERT_EQ(band->At(i, c, y, x), whole->At(i, c, cache->band_row0(b) + y, x))
                  << bits << "-bit, band " << b << ", image " << i;
    }
    const std::string dir = cache->dir();
    EXPECT_TRUE(fs::exists(dir));
    auto second = BandCache::Build(*shape, ro, co);
    ASSERT_TRUE(second.ok());
    *cache = std::move(*second);  // the first cache's files are removed with it
    EXPECT_FALSE(fs::exists(dir));
  }
}

// Two cameras 0.3° apart in an .lp: --view picks the nearest, so each reads as itself.
TEST(MultiView, AnLpViewIsTheNearestOneToTheAnglesAsked) {
  TempDir tmp;
  const fs::path dir = fs::path(tmp.path()) / "lp";
  fs::create_directories(dir);
  std::string lp = "8 views\n";
  const double thetas[2] = {22.0, 22.3};
  for (int v = 0; v < 2; ++v)
    for (int l = 0; l < 4; ++l) {
      const std::string name = "v" + std::to_string(v) + "_l" + std::to_string(l) + ".exr";
      ASSERT_TRUE(WriteImage((dir / name).string(), Image(4, 4, 3, 0.1f + 0.1f * v),
                             {PixelFormat::kFloat, TransferFunction::kLinear})
                      .ok());
      const Vec3 d = DirectionFromAnglesDeg(30, 90.0 * l);
      const Vec3 c = DirectionFromAnglesDeg(thetas[v], 0);
      char line[200];
      std::snprintf(line, sizeof line, "%s %.9f %.9f %.9f %.9f %.9f %.9f\n", name.c_str(), d.x, d.y,
                    d.z, c.x, c.y, c.z);
      lp += line;
    }
  std::ofstream(dir / "lights.lp") << lp;
  for (int v = 0; v < 2; ++v) {
    ReadOptions ro;
    ro.view = ViewAngles{thetas[v], 0};
    auto s = ReadDataset(dir.string(), ro);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    ASSERT_EQ(s->num_images(), 4);
    EXPECT_NEAR(s->view_theta_deg, thetas[v], 1e-6);
    EXPECT_NEAR(s->Sample(0, 0, 0), 0.1f + 0.1f * v, 1e-6) << "view " << v;
  }
  ReadOptions all;
  all.all_views = true;
  auto both = ReadDataset(dir.string(), all);
  ASSERT_TRUE(both.ok());
  EXPECT_EQ(ViewGroups(*both).size(), 2u);
}

TEST(MultiView, RefusesWhatCannotHoldSeveralViews) {
  synth::SynthOptions o;
  o.material = "lacquer";
  o.views = "dome:4";
  o.size = 8;
  o.layout = Layout::kDiligent;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--views needs --layout bonn, utia or lp"), std::string::npos) << why;
  o.layout = Layout::kBonn;
  o.material = "micro-stone";
  EXPECT_FALSE(o.Check(&why));
  o.material = "lacquer";
  o.near_lights = 100;
  EXPECT_FALSE(o.Check(&why));
  o.near_lights = 0;
  EXPECT_TRUE(o.Check(&why)) << why;
  // A multi-view stack in a layout that does not name the view.
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  TempDir tmp;
  DatasetWriteOptions wo;
  wo.layout = Layout::kDiligent;
  const Status st = WriteDataset(r->stack, wo, tmp.path());
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("bonn, utia or lp"), std::string::npos) << st.message();
  // --view all and one view at once.
  ReadOptions ro;
  ro.all_views = true;
  ro.view = ViewAngles{0, 0};
  EXPECT_FALSE(ro.Check(&why));
  // --view all of a layout that names no view.
  o.layout = Layout::kLp, o.views = "";
  ReadOptions all;
  all.all_views = true;
  auto read = WriteAndRead(o, tmp / "lp", all);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find("gives no view per image"), std::string::npos)
      << read.status().message();
  o.layout = Layout::kDiligent;
  read = WriteAndRead(o, tmp / "diligent", all);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find("--view all reads every view of a BTF"), std::string::npos)
      << read.status().message();
  // Two straight-down views that differ only in φv are one view twice.
  const std::string utia = tmp / "utia";
  fs::create_directories(utia);
  const Image img(4, 4, 3, 0.5f);
  for (const char* view : {"tv000_pv000", "tv000_pv090"})
    for (const char* light : {"tl000_pl000", "tl045_pl000", "tl045_pl120", "tl045_pl240"})
      ASSERT_TRUE(WriteImage(utia + "/" + light + "_" + view + ".png", img,
                             {PixelFormat::kUint16, TransferFunction::kLinear})
                      .ok());
  read = ReadDataset(utia, all);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find("are the same (straight-down) view"), std::string::npos)
      << read.status().message();
}

}  // namespace
}  // namespace matfit
