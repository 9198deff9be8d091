// DiLiGenT folders (core/dataset/diligent_reader.cc): filenames.txt, light_directions.txt and
// light_intensities.txt are cut from the input; images 001.png..006.png exist.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>

#include "core/dataset/dataset.h"
#include "fuzz/fuzz_util.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string d = fuzz::ScratchDir() + "/diligent";
    fuzz::WriteTinyImages(d, "00", ".png", 1, 6);
    return d;
  }();
  FuzzedDataProvider in(data, size);
  for (const char* name : {"/filenames.txt", "/light_directions.txt"}) {
    const std::string text = in.ConsumeRandomLengthString(4096);
    fuzz::WriteBytes(dir + name, reinterpret_cast<const uint8_t*>(text.data()), text.size());
  }
  const std::string rest = in.ConsumeRemainingBytesAsString();
  fuzz::WriteBytes(dir + "/light_intensities.txt", reinterpret_cast<const uint8_t*>(rest.data()),
                   rest.size());
  ReadOptions o;
  o.layout = Layout::kDiligent;
  (void)ReadDataset(dir, o);
  return 0;
}
