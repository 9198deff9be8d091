// The leaf pipeline: synthetic scans with ground truth, the shared real sheet, the flat field
// (the job and its files: leaf_job_test.cc).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "../core/test_util.h"
#include "core/image_io.h"
#include "leaf/flat_field.h"
#include "leaf/hl2.h"
#include "leaf/leaf_material.h"
#include "leaf/scan.h"
#include "leaf/sheet.h"
#include "leaf/synthetic_scan.h"

namespace matfit::leaf {
namespace {

SyntheticScanOptions Small() {
  SyntheticScanOptions o;
  o.leaf_size = 96, o.width = 168, o.height = 124;
  return o;
}

const Component* FirstLeaf(const Segmentation& s) {
  for (const auto& c : s.components)
    if (c.kind == ComponentKind::kLeaf) return &c;
  return nullptr;
}

double Pearson(const std::vector<double>& a, const std::vector<double>& b) {
  double ma = 0, mb = 0;
  for (size_t i = 0; i < a.size(); ++i) ma += a[i] / a.size(), mb += b[i] / b.size();
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sab += (a[i] - ma) * (b[i] - mb), saa += (a[i] - ma) * (a[i] - ma),
        sbb += (b[i] - mb) * (b[i] - mb);
  return sab / std::sqrt(saa * sbb);
}

TEST(LeafScan, SyntheticScanRecoversTheTruth) {
  const auto s = MakeSyntheticScan(Small());
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ASSERT_EQ(a->segmentation.leaves(), 1);
  int markers = 0;
  for (const auto& c : a->segmentation.components) markers += c.kind == ComponentKind::kMarker;
  EXPECT_EQ(markers, 4);
  const Component& leaf = *FirstLeaf(a->segmentation);
  // Segmentation against the true mask: intersection over union.
  int64_t inter = 0, uni = 0;
  for (int64_t i = 0; i < s.truth.mask.plane_size(); ++i) {
    const bool t = s.truth.mask.Plane(0)[i] > 0.5f, m = a->segmentation.labels[i] == leaf.label;
    inter += t && m, uni += t || m;
  }
  const double iou = double(inter) / uni;
  // Fused transmission inside the leaf (flat-fielded by the fitted back light).
  double terr = 0;
  int64_t tn = 0;
  for (int64_t i = 0; i < s.truth.mask.plane_size(); ++i)
    if (s.truth.mask.Plane(0)[i] > 0.5f && a->segmentation.labels[i] == leaf.label)
      for (int c = 0; c < 3; ++c) {
        const double t = s.truth.translucency.Plane(c)[i];
        if (t > 0.02) terr += std::abs(a->transmission.Plane(c)[i] - t) / t, ++tn;
      }
  terr /= tn;
  auto L = MakeLeafMaterial(s.scan, *a, leaf, 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  // Normals, albedo and thickness against the truth, over leaf texels fitted ok.
  double nerr = 0, aerr = 0;
  int64_t nn = 0;
  std::vector<double> est, truth;
  for (int y = 0; y < L->maps.height; ++y)
    for (int x = 0; x < L->maps.width; ++x) {
      const int64_t i = int64_t(y) * L->maps.width + x;
      const int X = L->crop_x + x, Y = L->crop_y + y;
      if (L->status[i] != 0 || s.truth.mask.At(0, Y, X) < 0.5f) continue;
      const Vec3 n(L->maps.normal.Plane(0)[i], L->maps.normal.Plane(1)[i],
                   L->maps.normal.Plane(2)[i]);
      const Vec3 t(s.truth.normal.At(0, Y, X), s.truth.normal.At(1, Y, X),
                   s.truth.normal.At(2, Y, X));
      nerr += std::acos(std::clamp(Dot(n, t), -1.0, 1.0)) * 180 / std::numbers::pi;
      aerr += std::abs(L->maps.albedo.Plane(1)[i] - s.truth.albedo.At(1, Y, X)) /
              s.truth.albedo.At(1, Y, X);
      est.push_back(L->maps.thickness.Plane(0)[i]), truth.push_back(s.truth.thickness.At(0, Y, X));
      ++nn;
    }
  nerr /= nn, aerr /= nn;
  const double r = Pearson(est, truth);
  std::printf(
      "synthetic scan: mask IoU %.4f, transmission error %.2f %%, normal MAE %.2f°, "
      "albedo (G) error %.2f %%, thickness estimate correlation r = %.4f (%lld texels)\n",
      iou, 100 * terr, nerr, 100 * aerr, r, (long long)nn);
  EXPECT_GE(iou, 0.97);
  EXPECT_LE(terr, 0.03);
  EXPECT_LE(nerr, 3.0);
  EXPECT_LE(aerr, 0.05);
  EXPECT_GE(r, 0.9);
  EXPECT_TRUE(L->thickness_estimated);
  EXPECT_FALSE(L->specular_fitted);  // one ring of lights: the leaf default
  // The HL2 maps are in the renderer's convention and finite.
  ASSERT_EQ(L->maps.hl2.channels(), 3);
  for (float v : L->maps.hl2.data()) EXPECT_TRUE(std::isfinite(v));
  EXPECT_LE(L->hl2_error[0].mean, 0.03);
}

TEST(LeafScan, MinimalFrontAndBackPhotos) {
  auto o = Small();
  o.minimal = true;
  const auto s = MakeSyntheticScan(o);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ASSERT_EQ(a->segmentation.leaves(), 1);
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  double aerr = 0;
  int64_t nn = 0;
  for (int64_t i = 0; i < L->maps.mask.plane_size(); ++i) {
    if (L->maps.mask.Plane(0)[i] < 0.5f) continue;
    EXPECT_EQ(L->maps.normal.Plane(2)[i], 1.0f);  // flat: no photometric stereo
    const int X = L->crop_x + int(i % L->maps.width), Y = L->crop_y + int(i / L->maps.width);
    if (s.truth.mask.At(0, Y, X) < 0.5f) continue;
    // A front light overhead: the photo is ρ (n·z) over the sheet's 1.
    const double want = s.truth.albedo.At(1, Y, X) * s.truth.normal.At(2, Y, X);
    aerr += std::abs(L->maps.albedo.Plane(1)[i] - want) / want, ++nn;
  }
  std::printf("minimal scan: albedo (G) error %.2f %% over %lld texels\n", 100 * aerr / nn,
              (long long)nn);
  EXPECT_LE(aerr / nn, 0.05);
}

TEST(LeafScan, LightsAtSeveralElevationsFitTheSpecularLobe) {
  auto o = Small();
  o.two_rings = true;
  const auto s = MakeSyntheticScan(o);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  EXPECT_TRUE(L->specular_fitted);
  // The synthetic upper side is Lambertian: the fitted lobe is weak.
  double f0 = 0;
  int64_t n = 0;
  for (int64_t i = 0; i < L->maps.mask.plane_size(); ++i)
    if (L->status[i] == 0) f0 += L->maps.specular.Plane(0)[i], ++n;
  std::printf("two rings: mean fitted F0 %.4f over %lld texels (truth: Lambertian)\n", f0 / n,
              (long long)n);
  EXPECT_LT(f0 / n, 0.02);
}

TEST(LeafScan, DisplacementScansGiveTheThickness) {
  auto o = Small();
  o.displacement = true;
  const auto s = MakeSyntheticScan(o);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok());
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  EXPECT_FALSE(L->thickness_estimated);
  double err = 0;
  int64_t n = 0;
  for (int y = 0; y < L->maps.height; ++y)
    for (int x = 0; x < L->maps.width; ++x) {
      const int64_t i = int64_t(y) * L->maps.width + x;
      if (L->maps.mask.Plane(0)[i] < 0.5f) continue;
      err += std::abs(L->maps.thickness.Plane(0)[i] -
                      s.truth.thickness.At(0, L->crop_y + y, L->crop_x + x)),
          ++n;
    }
  // max_thickness_mm is the truth's maximum, so the 99th-percentile rescale is nearly exact.
  std::printf("displacement thickness: MAE %.5f mm\n", err / n);
  EXPECT_LT(err / n, 0.01);
}

TEST(LeafScan, ALowerSideNormalScanShapesTheTranslucency) {
  auto s = MakeSyntheticScan(Small());
  // The lower surface tilted 30° toward +x' (its own frame), encoded rgb = n·0.5 + 0.5.
  const Vec3 n(0.5, 0, std::sqrt(0.75));
  s.scan.lower_normal = Image(s.scan.width(), s.scan.height(), 3);
  for (int64_t i = 0; i < s.scan.lower_normal.plane_size(); ++i)
    for (int c = 0; c < 3; ++c) s.scan.lower_normal.Plane(c)[i] = float(0.5 * n[c] + 0.5);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok());
  LeafMaterialOptions o;
  o.report_hl2_error = false;
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, o);
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  // Light from behind along ±x' at 45°: the side the lower surface faces transmits more.
  const Vec3 toward(std::sqrt(0.5), 0, std::sqrt(0.5)), away(-std::sqrt(0.5), 0, std::sqrt(0.5));
  double lt = 0, la = 0;
  for (int64_t i = 0; i < L->maps.mask.plane_size(); ++i) {
    if (L->maps.mask.Plane(0)[i] < 0.5f) continue;
    const std::array<double, 3> h = {L->maps.hl2.Plane(0)[i], L->maps.hl2.Plane(1)[i],
                                     L->maps.hl2.Plane(2)[i]};
    lt += Hl2Reconstruct(h, toward), la += Hl2Reconstruct(h, away);
  }
  // Expected (unshadowed): the HL2 projection of max(0, n·ω) reconstructed at the two lights.
  std::array<double, 3> hp{};
  for (const Vec3& w : StratifiedHemisphere(4096))
    for (int k = 0; k < 3; ++k)
      hp[k] += Hl2ProjectionWeight(4096) * Hl2Basis(k, w) * std::max(0.0, Dot(n, w));
  const double want = Hl2Reconstruct(hp, toward) / Hl2Reconstruct(hp, away);
  std::printf(
      "tilted lower normal: transmitted toward/away %.3f (projection of the clamped "
      "cosine: %.3f)\n",
      lt / la, want);
  EXPECT_GT(lt / la, 2.0);
  EXPECT_NEAR(lt / la, want, 0.05 * want);
}

TEST(LeafScan, GreyImagesWork) {
  auto s = MakeSyntheticScan(Small());
  // Grey top-lit and back-lit images (Rec. 709 luminance): no colour test for the markers.
  auto grey = [](const Image& im) {
    Image g(im.width(), im.height(), 1);
    for (int64_t i = 0; i < im.plane_size(); ++i)
      g.Plane(0)[i] =
          0.2126f * im.Plane(0)[i] + 0.7152f * im.Plane(1)[i] + 0.0722f * im.Plane(2)[i];
    return g;
  };
  for (auto& b : s.scan.back) b = grey(b);
  LightStack top(s.scan.top.width(), s.scan.top.height(), 1, s.scan.top.num_images());
  for (int k = 0; k < top.num_images(); ++k)
    for (int64_t i = 0; i < top.plane_size(); ++i)
      top.Plane(k, 0)[i] = 0.2126f * s.scan.top.Plane(k, 0)[i] +
                           0.7152f * s.scan.top.Plane(k, 1)[i] +
                           0.0722f * s.scan.top.Plane(k, 2)[i];
  top.lights() = s.scan.top.lights();
  s.scan.top = std::move(top);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_EQ(a->segmentation.leaves(), 1);
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  double nerr = 0;
  int64_t nn = 0;
  for (int64_t i = 0; i < L->maps.mask.plane_size(); ++i) {
    if (L->status[i] != 0) continue;
    const int X = L->crop_x + int(i % L->maps.width), Y = L->crop_y + int(i / L->maps.width);
    const Vec3 n(L->maps.normal.Plane(0)[i], L->maps.normal.Plane(1)[i],
                 L->maps.normal.Plane(2)[i]);
    const Vec3 tn(s.truth.normal.At(0, Y, X), s.truth.normal.At(1, Y, X),
                  s.truth.normal.At(2, Y, X));
    nerr += std::acos(std::clamp(Dot(n, tn), -1.0, 1.0)) * 180 / std::numbers::pi, ++nn;
  }
  EXPECT_LE(nerr / nn, 3.0);
  EXPECT_EQ(L->maps.translucency.channels(), 3);
}

TEST(LeafScan, FastMatchesTheReferenceOnARealLeaf) {
  MATFIT_REQUIRE_SHARED_DATA("leaf-sheet");
  auto scan = ReadLeafScan(shared_dir + "/leaf-sheet");
  ASSERT_TRUE(scan.ok()) << scan.status().ToString();
  auto a = AnalyzeSheet(*scan, SheetOptions{});
  ASSERT_TRUE(a.ok());
  const Component* big = nullptr;  // the largest leaf
  for (const auto& c : a->segmentation.components)
    if (c.kind == ComponentKind::kLeaf && (!big || c.area_px > big->area_px)) big = &c;
  ASSERT_NE(big, nullptr);
  LeafMaterialOptions o;
  o.report_hl2_error = false;
  // 0.25 mm/pixel: the scale of an A4 sheet across 500 pixels is about 0.6; finer makes the
  // kernel wider and the comparison harder.
  auto fast = MakeLeafMaterial(*scan, *a, *big, 0.25, o);
  o.reference_precompute = true;
  auto ref = MakeLeafMaterial(*scan, *a, *big, 0.25, o);
  ASSERT_TRUE(fast.ok() && ref.ok());
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    double d = 0, s = 0;
    for (int64_t i = 0; i < fast->maps.mask.plane_size(); ++i) {
      if (fast->maps.mask.Plane(0)[i] < 0.5f) continue;
      d += std::abs(fast->translucency.hl2_raw.Plane(c)[i] - ref->translucency.hl2_raw.Plane(c)[i]);
      s += std::abs(ref->translucency.hl2_raw.Plane(c)[i]);
    }
    std::printf("real leaf %d (%lld px): h%d fast vs reference mean relative difference %.4f %%\n",
                big->id, (long long)big->area_px, c + 1, 100 * d / s);
    worst = std::max(worst, d / s);
  }
  EXPECT_LE(worst, 0.01);
}

TEST(LeafScan, FindsEveryLeafOfTheSharedSheet) {
  MATFIT_REQUIRE_SHARED_DATA("leaf-sheet");
  auto scan = ReadLeafScan(shared_dir + "/leaf-sheet");
  ASSERT_TRUE(scan.ok()) << scan.status().ToString();
  EXPECT_EQ(scan->top.num_images(), 12);
  EXPECT_EQ(scan->back.size(), 12u);
  auto a = AnalyzeSheet(*scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  // Counted by eye on 1_TL.png: 23 leaves (several small, dry and curled), two twigs, four
  // fiducial markers and the white reference patch at the bottom left.
  int twigs = 0, markers = 0;
  for (const auto& c : a->segmentation.components) {
    if (c.kind == ComponentKind::kTwig && !c.touches_border) ++twigs;
    if (c.kind == ComponentKind::kMarker) ++markers;
    if (c.kind == ComponentKind::kLeaf) {
      EXPECT_GE(c.area_px, 100) << "leaf " << c.id;
      EXPECT_GT(c.chroma, 0.3) << "leaf " << c.id;  // no marker among the leaves
    }
  }
  EXPECT_EQ(a->segmentation.leaves(), 23);
  EXPECT_EQ(twigs, 2);
  EXPECT_EQ(markers, 5);
  // Stable ids: the same input gives the same numbering; ids run 1..23 in reading order.
  auto b = AnalyzeSheet(*scan, SheetOptions{});
  ASSERT_TRUE(b.ok());
  for (size_t k = 0; k < a->segmentation.components.size(); ++k) {
    const auto &p = a->segmentation.components[k], &q = b->segmentation.components[k];
    EXPECT_EQ(p.id, q.id);
    EXPECT_EQ(p.x0, q.x0);
    EXPECT_EQ(p.y0, q.y0);
  }
  EXPECT_EQ(a->segmentation.components[0].id, 1);
  EXPECT_LT(a->segmentation.components[0].cy, a->segmentation.components[22].cy);
  // The fall-off across the frame is real (near lights; a third of the pixels clip) and the flat
  // field removes it. Measured on the unclipped bare sheet by a 3 × 3 grid of cells (cells whose
  // sheet is mostly unclipped: in a mostly clipped cell the unclipped pixels are the shadowed
  // ones; medians, since cast shadows are a minority): the ratio of the
  // brightest to the darkest cell drops from 1.2–3.4× to < 1.1×, and the flat-fielded sheet reads
  // cos θ = 0.707 (median) within 5 %.
  for (int m = 0; m < a->top.num_images(); ++m) {
    std::vector<float> flat, cell_raw[9], cell_flat[9], clipped;
    int64_t cell_all[9] = {};
    for (int64_t i = 0; i < a->top.plane_size(); ++i) {
      if (!a->background[i]) continue;
      const float r = scan->top.Sample(m, 1, i), f = a->top.Plane(m, 1)[i];
      ++cell_all[3 * int(3 * (i / a->width) / a->height) + int(3 * (i % a->width) / a->width)];
      if (r >= 0.995f) {
        clipped.push_back(f);
        continue;
      }
      flat.push_back(f);
      const int cell = 3 * int(3 * (i / a->width) / a->height) + int(3 * (i % a->width) / a->width);
      cell_raw[cell].push_back(r), cell_flat[cell].push_back(f);
    }
    auto pct = [](std::vector<float> v, double p) {
      std::nth_element(v.begin(), v.begin() + size_t(p * (v.size() - 1)), v.end());
      return double(v[size_t(p * (v.size() - 1))]);
    };
    double rmin = 1e9, rmax = 0, fmin = 1e9, fmax = 0;
    for (int c = 0; c < 9; ++c) {
      if (cell_raw[c].size() < 1000 || 2 * int64_t(cell_raw[c].size()) < cell_all[c]) continue;
      const double r = pct(cell_raw[c], 0.5), f = pct(cell_flat[c], 0.5);
      rmin = std::min(rmin, r), rmax = std::max(rmax, r), fmin = std::min(fmin, f),
      fmax = std::max(fmax, f);
    }
    std::printf("top-lit %2d: cell medians spread %.3fx raw, %.3fx flat-fielded; median %.4f\n",
                m + 1, rmax / rmin, fmax / fmin, pct(flat, 0.5));
    EXPECT_GT(rmax / rmin, 1.1) << "image " << m + 1;
    EXPECT_LT(fmax / fmin, 1.1) << "image " << m + 1;
    EXPECT_LT(fmax / fmin, rmax / rmin) << "image " << m + 1;
    EXPECT_NEAR(pct(flat, 0.5), 0.7071, 0.05 * 0.7071) << "image " << m + 1;
    // Clipped samples stay marked (exactly 1) so that photometric stereo drops them.
    for (float c : clipped) ASSERT_EQ(c, 1.0f) << "image " << m + 1;
  }
}

TEST(LeafScan, ThinLeavesAreFlaggedNotCrashed) {
  auto s = MakeSyntheticScan(Small());
  s.scan.max_thickness_mm = 0.12;  // below the model's 1.5 l ≈ 0.152 mm almost everywhere
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok());
  auto L = MakeLeafMaterial(s.scan, *a, *FirstLeaf(a->segmentation), 0.2, LeafMaterialOptions{});
  ASSERT_TRUE(L.ok()) << L.status().ToString();
  int64_t thin = 0;
  for (uint8_t st : L->status) thin += st == kLeafTexelThin;
  EXPECT_GT(thin, 0);
  EXPECT_EQ(thin, L->translucency.thin_texels);
  bool warned = false;
  for (const auto& w : L->warnings) warned = warned || w.find("validity") != std::string::npos;
  EXPECT_TRUE(warned);
  for (float v : L->maps.hl2.data()) EXPECT_TRUE(std::isfinite(v));
}

TEST(LeafScan, LeafCutByTheBorderIsMarked) {
  auto s = MakeSyntheticScan(Small());
  // Cut the frame through the leaf: keep columns from the leaf's middle on.
  const int cut = s.leaf_x0 + s.scan.width() / 8 + 20;
  auto crop = [&](const Image& im) {
    Image o(im.width() - cut, im.height(), im.channels());
    for (int c = 0; c < im.channels(); ++c)
      for (int y = 0; y < im.height(); ++y)
        for (int x = cut; x < im.width(); ++x) o.At(c, y, x - cut) = im.At(c, y, x);
    return o;
  };
  for (auto& b : s.scan.back) b = crop(b);
  LightStack top(s.scan.top.width() - cut, s.scan.top.height(), 3, s.scan.top.num_images());
  for (int k = 0; k < top.num_images(); ++k)
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < top.height(); ++y)
        for (int x = 0; x < top.width(); ++x)
          top.Plane(k, c)[int64_t(y) * top.width() + x] = s.scan.top.At(k, c, y, x + cut);
  top.lights() = s.scan.top.lights();
  s.scan.top = std::move(top);
  auto a = AnalyzeSheet(s.scan, SheetOptions{});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  const Component* leaf = FirstLeaf(a->segmentation);
  ASSERT_NE(leaf, nullptr);
  EXPECT_TRUE(leaf->touches_border);
}

TEST(FlatField, CensoredFitSeesThroughClipping) {
  // A Gaussian fall-off peaking at 1.3 × the clip level in the middle of the frame: log I is
  // quadratic, so the fit is exact where unclipped, and the clipped centre must come out above 1.
  const int w = 120, h = 90;
  Image img(w, h, 1);
  std::vector<uint8_t> bg(size_t(w) * h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double u = 2.0 * x / (w - 1) - 1, v = 2.0 * y / (h - 1) - 1;
      img.At(0, y, x) = float(std::min(1.0, 1.3 * std::exp(-(u * u + v * v))));
    }
  auto fit = FitBackground(img.Plane(0), w, h, bg, BackgroundOptions{});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_NEAR(fit->level.At(0, h / 2, w / 2), 1.3, 0.05);           // the hidden peak
  EXPECT_NEAR(fit->level.At(0, 0, 0), 1.3 * std::exp(-2.0), 0.01);  // a corner, unclipped
  // Too little unclipped background: a clear error.
  Image white(w, h, 1, 1.0f);
  auto none = FitBackground(white.Plane(0), w, h, bg, BackgroundOptions{});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("unclipped"), std::string::npos);
}

}  // namespace
}  // namespace matfit::leaf
