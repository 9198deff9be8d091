#include "core/image.h"

#include "core/parallel.h"

namespace matfit {

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels) {
  MATFIT_CHECK(width >= 0 && height >= 0 && channels >= 0);
  data_.resize(size_t(width) * height * channels);  // default-initialised: no page touched yet
  ParallelFill(data_.data(), data_.size(), fill);
}

}  // namespace matfit
