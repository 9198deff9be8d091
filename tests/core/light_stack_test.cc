#include <gtest/gtest.h>

#include <set>

#include "core/light_stack.h"
#include "core/tiles.h"

namespace matfit {
namespace {

TEST(LightStack, PlaneMajorLayout) {
  LightStack s(5, 3, 3, 4);
  s.Plane(2, 1)[2 * 5 + 4] = 7.0f;
  EXPECT_EQ(s.At(2, 1, 2, 4), 7.0f);
  // data[((i*C + c)*H + y)*W + x]
  EXPECT_EQ(s.data()[((2 * 3 + 1) * 3 + 2) * 5 + 4], 7.0f);
  EXPECT_EQ(s.Plane(2, 1)[2 * 5 + 4], 7.0f);
  EXPECT_EQ(s.MemoryBytes(), size_t(5 * 3 * 3 * 4 * 4));
  EXPECT_EQ(s.lights().size(), 4u);
  EXPECT_EQ(s.MaskedTexels(), 15);
  s.mask.assign(15, 0);
  s.mask[3] = 1;
  EXPECT_EQ(s.MaskedTexels(), 1);
}

// ReleaseSamples gives the samples' memory back and keeps the description (size, lights, mask,
// table); a converted copy or a plane of codes afterwards is refused (per-sample reads: in
// debug builds).
TEST(LightStack, ReleaseSamplesKeepsTheDescription) {
  std::vector<float> lut(256);
  for (int k = 0; k < 256; ++k) lut[size_t(k)] = float(k) / 255;
  LightStack s(64, 48, 3, 10, SampleType::kUint8, lut);
  s.lights()[3] = LightFromDirection(Vec3(0.3, 0.1, 1));
  s.mask.assign(size_t(s.plane_size()), 1);
  s.mm_per_texel = 0.25;
  const size_t before = s.MemoryBytes();
  EXPECT_EQ(before, size_t(64 * 48 * 3 * 10) + 256 * sizeof(float) + size_t(64 * 48));
  s.ReleaseSamples();
  EXPECT_TRUE(s.samples_released());
  EXPECT_EQ(s.MemoryBytes(), before - size_t(64 * 48 * 3 * 10));
  EXPECT_EQ(s.width(), 64);
  EXPECT_EQ(s.height(), 48);
  EXPECT_EQ(s.num_images(), 10);
  EXPECT_EQ(s.lights()[3].direction, LightFromDirection(Vec3(0.3, 0.1, 1)).direction);
  EXPECT_EQ(s.MaskedTexels(), 64 * 48);
  EXPECT_EQ(s.mm_per_texel, 0.25);
  EXPECT_DEATH((void)s.ToFloat(), "ReleaseSamples");
  EXPECT_DEATH((void)s.Codes<uint8_t>(0, 0), "ReleaseSamples");
}

TEST(Tiles, CoverEveryTexelExactlyOnce) {
  for (int tile : {1, 7, 16, 100}) {
    const auto tiles = MakeTiles(37, 23, tile);
    std::vector<int> hits(37 * 23, 0);
    for (const Tile& t : tiles) {
      EXPECT_LE(t.width, tile);
      EXPECT_LE(t.height, tile);
      for (int y = 0; y < t.height; ++y)
        for (int x = 0; x < t.width; ++x) hits[(t.y0 + y) * 37 + t.x0 + x]++;
    }
    for (int h : hits) EXPECT_EQ(h, 1);
  }
}

TEST(Tiles, RowStripsCoverEveryRowOnce) {
  const auto strips = MakeRowStrips(37, 23, 5);
  ASSERT_EQ(strips.size(), 5u);
  int rows = 0;
  for (const Tile& t : strips) {
    EXPECT_EQ(t.x0, 0);
    EXPECT_EQ(t.width, 37);
    EXPECT_EQ(t.y0, rows);
    rows += t.height;
  }
  EXPECT_EQ(rows, 23);
}

TEST(Tiles, ViewMapsLocalToGlobal) {
  LightStack s(10, 8, 1, 2);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 10; ++x) s.Plane(1, 0)[y * 10 + x] = float(100 * y + x);
  StackTileView v(s, Tile{4, 3, 5, 4});
  EXPECT_EQ(v.At(1, 0, 0, 0), 304.0f);
  float scratch[5];
  EXPECT_EQ(v.Row(1, 0, 2, scratch)[3], 507.0f);
  EXPECT_EQ(v.GlobalIndex(2, 3), 5 * 10 + 7);
}

}  // namespace
}  // namespace matfit
