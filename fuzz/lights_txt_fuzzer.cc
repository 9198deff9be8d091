// lights.txt + numbered images (core/dataset/lights_txt_reader.cc): the light file is the input.
#include <cstddef>
#include <cstdint>

#include "core/dataset/dataset.h"
#include "core/dataset/info.h"
#include "fuzz/fuzz_util.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string d = fuzz::ScratchDir() + "/obj";
    fuzz::WriteTinyImages(d, "obj.", ".png", 0, 6);
    return d;
  }();
  fuzz::WriteBytes(dir + "/lights.txt", data, size);
  ReadOptions o;
  o.layout = Layout::kLightsTxt;
  auto s = ReadDataset(dir, o);
  if (s.ok()) (void)ComputeDatasetInfo(*s);
  return 0;
}
