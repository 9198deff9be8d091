// Image files (core/image_io.cc + the native codecs, core/codec_{jpeg,png,exr}.cc): the input is
// a whole file. Files the native backend declines (other formats, palette PNGs, ...) are left
// alone: OpenImageIO reads those, and this target is about matfit's own decoding path.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/image_codec.h"
#include "core/image_io.h"
#include "fuzz/fuzz_util.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = fuzz::ScratchDir() + "/image";
  fuzz::WriteBytes(path, data, size);
  std::string error;
  if (!codec::Native().Open(path, &error) && error.empty()) return 0;  // declined
  ImageReadOptions o;
  o.confine_to = fuzz::ScratchDir();
  (void)ReadImageHeader(path, o);
  (void)ReadImageNative(path, o);
  o.all_channels = true;
  (void)ReadImage(path, o);
  return 0;
}
