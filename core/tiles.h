// Tiles: rectangular pieces of the texel grid that parallel kernels process independently.
#pragma once

#include <cstdint>
#include <vector>

#include "core/light_stack.h"

namespace matfit {

struct Tile {
  int x0 = 0, y0 = 0, width = 0, height = 0;
  int64_t texels() const { return int64_t(width) * height; }
};

// Covers width × height with tiles of at most tile_size², row-major order; the last row and
// column of tiles are clipped. tile_size must be > 0.
std::vector<Tile> MakeTiles(int width, int height, int tile_size);

// Full-width strips of `rows` rows (the last one clipped): kernels that stream plane rows
// image by image run 2–3× faster on long contiguous rows than on narrow square tiles.
std::vector<Tile> MakeRowStrips(int width, int height, int rows);

// Read-only view of a LightStack restricted to one tile; coordinates are tile-local.
class StackTileView {
 public:
  StackTileView(const LightStack& stack, const Tile& tile) : stack_(&stack), tile_(tile) {
    MATFIT_CHECK(tile.x0 >= 0 && tile.y0 >= 0 && tile.x0 + tile.width <= stack.width() &&
                 tile.y0 + tile.height <= stack.height());
  }
  const Tile& tile() const { return tile_; }
  int width() const { return tile_.width; }
  int height() const { return tile_.height; }
  int num_images() const { return stack_->num_images(); }
  int channels() const { return stack_->channels(); }
  // Tile-local row y of (image, channel) as width() linear floats (LightStack::Row: into the
  // planes for float stacks, decoded into scratch, width() floats, otherwise).
  const float* Row(int image, int channel, int y, float* scratch) const {
    MATFIT_DCHECK(y >= 0 && y < tile_.height);
    return stack_->Row(image, channel, tile_.y0 + y, tile_.x0, tile_.width, scratch);
  }
  float At(int image, int channel, int y, int x) const {
    MATFIT_DCHECK(x >= 0 && x < tile_.width && y >= 0 && y < tile_.height);
    return stack_->At(image, channel, tile_.y0 + y, tile_.x0 + x);
  }
  // Texel index in the full plane of tile-local (y, x).
  int64_t GlobalIndex(int y, int x) const {
    return int64_t(tile_.y0 + y) * stack_->width() + tile_.x0 + x;
  }

 private:
  const LightStack* stack_;
  Tile tile_;
};

}  // namespace matfit
