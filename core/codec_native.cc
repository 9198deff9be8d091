// The native backend: picks the codec by the file's first bytes (reading) or the extension
// (writing); everything else is declined for OpenImageIO.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "core/codec_native.h"

namespace matfit::codec {
namespace {

enum class Kind { kOther, kJpeg, kPng, kExr };

Kind Sniff(const std::string& path) {
  unsigned char m[8] = {};
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return Kind::kOther;
  const size_t n = std::fread(m, 1, sizeof m, f);
  std::fclose(f);
  if (n >= 3 && m[0] == 0xFF && m[1] == 0xD8 && m[2] == 0xFF) return Kind::kJpeg;
  if (n == 8 && std::memcmp(m, "\x89PNG\r\n\x1a\n", 8) == 0) return Kind::kPng;
  if (n >= 4 && m[0] == 0x76 && m[1] == 0x2f && m[2] == 0x31 && m[3] == 0x01) return Kind::kExr;
  return Kind::kOther;
}

class NativeBackend : public Backend {
 public:
  std::unique_ptr<Reader> Open(const std::string& path, std::string* error) override {
    switch (Sniff(path)) {
      case Kind::kJpeg: return OpenJpeg(path, error);
      case Kind::kPng: return OpenPng(path, error);
      case Kind::kExr: return OpenExr(path, error);
      case Kind::kOther: break;
    }
    return nullptr;
  }

  bool CanWrite(const std::string& format, const WriteSpec& spec, bool in_memory) const override {
    const bool integer = spec.sample == Sample::kUint8 || spec.sample == Sample::kUint16;
    // PNG with alpha goes to OpenImageIO (straight alpha: colour stored as given, read back as
    // stored).
    if (format == "png") return integer && (spec.channels == 1 || spec.channels == 3);
    // JPEG at an explicit quality (the relight planes); other JPEG writes keep OpenImageIO's.
    if (format == "jpg")
      return spec.sample == Sample::kUint8 && (spec.channels == 1 || spec.channels == 3) &&
             spec.jpeg_quality > 0 && !in_memory;
    return format == "exr" && !integer && !in_memory;
  }

  bool Write(const std::string& format, const WriteSpec& spec, const std::string& path,
             std::string* memory, std::string* error) override {
    if (format == "png") return WritePng(spec, path, memory, error);
    if (format == "exr" && !memory) return WriteExr(spec, path, error);
    if (format == "jpg" && !memory) return WriteJpeg(spec, path, error);
    *error = "the native codecs do not write '" + format + "'" + (memory ? " in memory" : "");
    return false;
  }
};

}  // namespace

Backend& Native() {
  static NativeBackend backend;
  return backend;
}

}  // namespace matfit::codec
