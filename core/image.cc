#include "core/image.h"

namespace matfit {

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels) {
  MATFIT_CHECK(width >= 0 && height >= 0 && channels >= 0);
  data_.assign(size_t(width) * height * channels, fill);
}

}  // namespace matfit
