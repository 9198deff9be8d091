// The segmentation picture's leaf numbers (leaf/overlay.h): drawn numerals read back by sampling
// the glyph cells, on a blank image and in a leaf job's segmentation.png at the centroid that
// leaves.json reports, matching the leaf's id.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "../core/test_util.h"
#include "core/image_io.h"
#include "leaf/leaf_job.h"
#include "leaf/overlay.h"
#include "leaf/scan.h"
#include "leaf/synthetic_scan.h"

namespace matfit::leaf {
namespace {

namespace fs = std::filesystem;
using matfit::testing::TempDir;

// Reads the numeral DrawNumber put at `l` (-1 where a glyph matches no digit or the box is not
// black around it): each cell's centre pixel is white (> 0.9) or black (< 0.1).
int ReadNumber(const Image& img, const NumberLayout& l) {
  auto px = [&](int x, int y) { return img.At(1, y, x); };
  int value = 0;
  for (int k = 0; k < l.digits; ++k) {
    int found = -1;
    for (int d = 0; d < 10 && found < 0; ++d) {
      bool all = true;
      for (int gy = 0; gy < 5 && all; ++gy)
        for (int gx = 0; gx < 3 && all; ++gx) {
          const float v =
              px(l.x0 + (4 * k + gx) * l.scale + l.scale / 2, l.y0 + gy * l.scale + l.scale / 2);
          all = DigitCell(d, gx, gy) ? v > 0.9f : v < 0.1f;
        }
      if (all) found = d;
    }
    if (found < 0) return -1;
    value = 10 * value + found;
  }
  // The black frame one cell wide around the numeral.
  const int w = (4 * l.digits - 1) * l.scale;
  for (int x = l.x0 - l.scale; x < l.x0 + w + l.scale; ++x)
    if (px(x, l.y0 - l.scale) > 0.1f || px(x, l.y0 + 5 * l.scale) > 0.1f) return -1;
  return value;
}

TEST(SegmentationNumbers, DrawnNumeralsReadBack) {
  Image img(120, 60, 3, 0.5f);
  for (const auto& [n, cx, scale] :
       {std::tuple{7, 20.0, 3}, std::tuple{12, 70.0, 4}, std::tuple{305, 60.0, 2}}) {
    DrawNumber(&img, n, cx, n == 305 ? 50.0 : 25.0, scale);
    EXPECT_EQ(ReadNumber(img, LayoutNumber(n, cx, n == 305 ? 50.0 : 25.0, scale)), n) << n;
  }
  // Numerals near an edge are clipped, not written out of bounds.
  DrawNumber(&img, 99, 0, 0, 5);
  DrawNumber(&img, 99, 119, 59, 5);
  for (const auto& [x, y] : {std::pair{0, 0}, std::pair{119, 59}})
    EXPECT_TRUE(img.At(1, y, x) == 0.0f || img.At(1, y, x) == 1.0f) << "no numeral at a corner";
}

TEST(SegmentationNumbers, ScaleFollowsTheSheetAndFitsTheLeaf) {
  EXPECT_EQ(NumberScale(4000, 3000, 800, 900, 1), 30);  // 1/100 of the short side
  EXPECT_EQ(NumberScale(4000, 3000, 50, 900, 2), 5);    // 9 cells across 50 px
  EXPECT_EQ(NumberScale(100, 80, 4, 4, 1), 1);          // never below one pixel
}

TEST(SegmentationNumbers, TheLeafJobNumbersEachLeafWithItsId) {
  TempDir tmp;
  SyntheticScanOptions so;
  so.leaf_size = 96, so.width = 168, so.height = 124;
  ASSERT_TRUE(WriteLeafScan(MakeSyntheticScan(so), tmp / "scan", false).ok());
  LeafJobOptions o;
  o.input = tmp / "scan", o.out = tmp / "out";
  auto r = RunLeafJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  std::ifstream in(tmp / "out/leaves.json");
  const auto index = nlohmann::json::parse(in);
  ImageReadOptions raw;
  raw.color_space = ColorSpaceChoice::kLinear;
  auto seg = ReadImage(tmp / "out/segmentation.png", raw);
  ASSERT_TRUE(seg.ok()) << seg.status().ToString();
  ASSERT_GE(index["leaves"].size(), 1u);
  for (const auto& leaf : index["leaves"]) {
    const int id = leaf["id"];
    const auto& b = leaf["bbox"];
    const int digits = int(std::to_string(id).size());
    const int scale = NumberScale(seg->width(), seg->height(), b[2], b[3], digits);
    const NumberLayout l = LayoutNumber(id, leaf["centroid"][0], leaf["centroid"][1], scale);
    EXPECT_EQ(ReadNumber(*seg, l), id) << "leaf " << id << " at scale " << scale;
    EXPECT_EQ(leaf["name"], "leaf_0" + std::to_string(id));
  }
}

}  // namespace
}  // namespace matfit::leaf
