#include "fuzz/fuzz_util.h"

#include <unistd.h>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/image.h"
#include "core/image_io.h"

namespace matfit::fuzz {
namespace fs = std::filesystem;

namespace {
struct Scratch {
  std::string path;
  Scratch() {
    const char* tmp = std::getenv("TMPDIR");
    path = (fs::path(tmp && *tmp ? tmp : "/tmp") / ("matfit-fuzz-" + std::to_string(getpid())))
               .string();
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
}  // namespace

const std::string& ScratchDir() {
  static Scratch s;
  return s.path;
}

void WriteBytes(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
}

void WriteTinyImages(const std::string& dir, const std::string& prefix, const std::string& suffix,
                     int first, int count, int width) {
  fs::create_directories(dir);
  for (int i = first; i < first + count; ++i) {
    Image img(width, width, 3);
    for (size_t k = 0; k < img.data().size(); ++k) img.data()[k] = float((k * 7 + i) % 97) / 97.0f;
    const std::string path = (fs::path(dir) / (prefix + std::to_string(i) + suffix)).string();
    if (!WriteImage(path, img, {PixelFormat::kUint16, TransferFunction::kLinear}).ok())
      std::abort();
  }
}

}  // namespace matfit::fuzz
