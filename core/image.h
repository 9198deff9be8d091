// Image: `channels` float32 planes of width × height, plane-major ([channel][row][col]).
// Row 0 is the top row of the picture (as displayed), column 0 the left column.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/check.h"
#include "core/large_page_allocator.h"

namespace matfit {

class Image {
 public:
  // The samples. Big buffers are 2 MiB-aligned and advised for huge pages; the constructor
  // fills a big one on every thread (each page first touched by the thread that fills it), so
  // fitted maps and coefficient planes are not zero-filled by one thread while the other waits.
  using Buffer = std::vector<float, LargePageAllocator<float>>;

  Image() = default;
  // Every sample = fill.
  Image(int width, int height, int channels, float fill = 0.0f);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  int64_t plane_size() const { return int64_t(width_) * height_; }

  std::span<float> Plane(int c) {
    MATFIT_DCHECK(c >= 0 && c < channels_);
    return {data_.data() + c * plane_size(), size_t(plane_size())};
  }
  std::span<const float> Plane(int c) const {
    MATFIT_DCHECK(c >= 0 && c < channels_);
    return {data_.data() + c * plane_size(), size_t(plane_size())};
  }
  float& At(int c, int y, int x) {
    MATFIT_DCHECK(c >= 0 && c < channels_ && y >= 0 && y < height_ && x >= 0 && x < width_);
    return data_[(int64_t(c) * height_ + y) * width_ + x];
  }
  float At(int c, int y, int x) const {
    MATFIT_DCHECK(c >= 0 && c < channels_ && y >= 0 && y < height_ && x >= 0 && x < width_);
    return data_[(int64_t(c) * height_ + y) * width_ + x];
  }
  Buffer& data() { return data_; }
  const Buffer& data() const { return data_; }
  size_t MemoryBytes() const { return data_.size() * sizeof(float); }

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  Buffer data_;
};

}  // namespace matfit
