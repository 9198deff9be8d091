#include "core/tiles.h"

#include <algorithm>

namespace matfit {

std::vector<Tile> MakeTiles(int width, int height, int tile_size) {
  MATFIT_CHECK(tile_size > 0);
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += tile_size)
    for (int x = 0; x < width; x += tile_size)
      tiles.push_back({x, y, std::min(tile_size, width - x), std::min(tile_size, height - y)});
  return tiles;
}

std::vector<Tile> MakeRowStrips(int width, int height, int rows) {
  MATFIT_CHECK(rows > 0);
  std::vector<Tile> strips;
  for (int y = 0; y < height; y += rows)
    strips.push_back({0, y, width, std::min(rows, height - y)});
  return strips;
}

}  // namespace matfit
