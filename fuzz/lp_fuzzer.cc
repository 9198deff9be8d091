// RTI .lp light files (core/dataset/lp_reader.cc): the .lp text is the input; images img0..img5
// exist beside it.
#include <cstddef>
#include <cstdint>

#include "core/dataset/dataset.h"
#include "core/dataset/info.h"
#include "fuzz/fuzz_util.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string d = fuzz::ScratchDir() + "/lp";
    fuzz::WriteTinyImages(d, "img", ".png", 0, 6);
    return d;
  }();
  fuzz::WriteBytes(dir + "/set.lp", data, size);
  ReadOptions o;
  o.layout = Layout::kLp;
  auto s = ReadDataset(dir + "/set.lp", o);
  if (s.ok()) (void)ComputeDatasetInfo(*s);
  return 0;
}
