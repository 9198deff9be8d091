// The OpenImageIO backend, built as a module (libmatfit_oiio.so) that core loads with dlopen
// when a file needs it (core/image_codec.h says why). Uses nothing from the rest of matfit.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/codec_file.h"
#include "core/image_codec.h"

namespace matfit::codec {
namespace {

std::string LastError(OIIO::ImageInput* in) {
  std::string e = in ? in->geterror() : std::string();
  if (e.empty()) e = OIIO::geterror();
  if (e.empty()) e = "unknown decoder error";
  std::replace(e.begin(), e.end(), '\n', ' ');  // one line: decoders append newlines
  return e;
}

class OiioReader : public Reader {
 public:
  explicit OiioReader(std::unique_ptr<OIIO::ImageInput> in) : in_(std::move(in)) {
    const OIIO::ImageSpec& s = in_->spec();
    h_.width = s.width, h_.height = s.height, h_.channels = s.nchannels;
    h_.volume = s.depth > 1 || s.deep;
    const auto base = s.format.basetype;
    h_.sample = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8     ? Sample::kUint8
                : base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16 ? Sample::kUint16
                : base == OIIO::TypeDesc::HALF                                    ? Sample::kHalf
                                                                                  : Sample::kFloat;
    h_.color_space = s.get_string_attribute("oiio:ColorSpace");
    h_.gamma = s.get_float_attribute("oiio:Gamma", 0.0f);
    h_.software = s.get_string_attribute("Software");
    h_.software_known = true;
  }
  ~OiioReader() override { in_->close(); }
  const Header& header() const override { return h_; }
  bool ReadRows(int y0, int y1, void* dst) override {
    const OIIO::ImageSpec& s = in_->spec();
    const OIIO::TypeDesc want = h_.sample == Sample::kUint8    ? OIIO::TypeDesc::UINT8
                                : h_.sample == Sample::kUint16 ? OIIO::TypeDesc::UINT16
                                                               : OIIO::TypeDesc::FLOAT;
    // The file's own type is asked for as "native" (TypeDesc::UNKNOWN): OpenImageIO 2.4 then
    // decodes straight into dst, where an explicit type, even the same one, goes through a
    // 64 MiB staging buffer that is mapped, faulted in and unmapped for every image.
    const OIIO::TypeDesc type = want == s.format ? OIIO::TypeDesc::UNKNOWN : want;
    if (y0 == 0 && y1 == s.height)
      return in_->read_image(0, 0, 0, s.nchannels, type, dst) && !in_->has_error();
    if (s.tile_width == 0)  // scanline files: only the band's rows
      return in_->read_scanlines(0, 0, s.y + y0, s.y + y1, 0, 0, s.nchannels, type, dst) &&
             !in_->has_error();
    // Tiled files (scanline reads are refused on them): the whole image, then the band's rows.
    const size_t row = size_t(s.width) * s.nchannels * want.size();
    std::vector<unsigned char> whole(row * size_t(s.height));
    if (!in_->read_image(0, 0, 0, s.nchannels, want, whole.data()) || in_->has_error())
      return false;
    std::memcpy(dst, whole.data() + row * size_t(y0), row * size_t(y1 - y0));
    return true;
  }
  std::string error() const override { return LastError(in_.get()); }

 private:
  std::unique_ptr<OIIO::ImageInput> in_;
  Header h_;
};

// OpenImageIO's writes to a file, keeping the first error (errno): some writers ignore short
// writes, and a full disk gave empty PNG files that "succeeded".
class CheckedFileOutput : public OIIO::Filesystem::IOFile {
 public:
  explicit CheckedFileOutput(FILE* f) : IOFile(f, Write) {}
  size_t write(const void* buf, size_t size) override {
    return Checked(IOFile::write(buf, size), size);
  }
  size_t pwrite(const void* buf, size_t size, int64_t offset) override {
    return Checked(IOFile::pwrite(buf, size, offset), size);
  }
  int error() const { return error_; }

 private:
  size_t Checked(size_t written, size_t size) {
    if (written != size && error_ == 0) error_ = errno != 0 ? errno : EIO;
    return written;
  }
  int error_ = 0;
};

bool EncodeInto(OIIO::ImageOutput* out, const std::string& file_name,
                OIIO::Filesystem::IOProxy* proxy, const WriteSpec& w) {
  const OIIO::TypeDesc type = w.sample == Sample::kUint8    ? OIIO::TypeDesc::UINT8
                              : w.sample == Sample::kUint16 ? OIIO::TypeDesc::UINT16
                              : w.sample == Sample::kHalf   ? OIIO::TypeDesc::HALF
                                                            : OIIO::TypeDesc::FLOAT;
  OIIO::ImageSpec spec(w.width, w.height, w.channels, type);
  if (w.channels > 4) {
    // Data maps with many planes: EXR sorts channels by name, so name them in numeric order.
    spec.channelnames.clear();
    char name[16];
    for (int c = 0; c < w.channels; ++c)
      std::snprintf(name, sizeof name, "ch%02d", c), spec.channelnames.push_back(name);
    spec.alpha_channel = -1;
  }
  spec.attribute("oiio:ColorSpace", w.srgb ? "sRGB" : "Linear");
  // matfit's images hold colour and alpha as separate values (straight alpha): stored as they
  // are, never divided by alpha (as OpenImageIO does for associated colour).
  spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("Software", w.software);
  if (!w.srgb) spec.attribute("oiio:Gamma", 1.0f);
  const bool is_float = w.sample == Sample::kHalf || w.sample == Sample::kFloat;
  if (is_float && std::strcmp(out->format_name(), "openexr") == 0)
    spec.attribute("compression", w.compact ? "piz" : "none");
  if (std::strcmp(out->format_name(), "png") == 0)
    spec.attribute("png:compressionLevel", w.compact ? 6 : 1);
  if (std::strcmp(out->format_name(), "jpeg") == 0 && w.jpeg_quality > 0) {
    spec.attribute("Compression", "jpeg:" + std::to_string(std::clamp(w.jpeg_quality, 1, 100)));
    spec.attribute("jpeg:subsampling", "4:4:4");
  }
  const OIIO::TypeDesc buffer_type = is_float ? OIIO::TypeDesc::FLOAT : type;
  if (proxy) out->set_ioproxy(proxy);
  if (!out->open(file_name, spec)) return false;
  bool written = true;
  for (int y0 = 0; y0 < w.height && written; y0 += w.strip_rows) {
    const int y1 = std::min(w.height, y0 + w.strip_rows);
    written = out->write_scanlines(y0, y1, 0, buffer_type, w.rows(y0, y1));
  }
  return out->close() && written;
}

class OiioBackend : public Backend {
 public:
  std::unique_ptr<Reader> Open(const std::string& path, std::string* error) override {
    // Camera RAW (libraw): linear values (sRGB/Rec.709 primaries, no gamma, no automatic
    // brightening), white-balanced with the camera's as-shot multipliers. Other formats ignore
    // these hints.
    OIIO::ImageSpec config;
    config.attribute("raw:ColorSpace", "linear");
    config.attribute("raw:use_camera_wb", 1);
    config.attribute("raw:auto_bright", 0);
    // Colours as stored, not multiplied by alpha: the alpha channel is a mask, and a sample's
    // value must not depend on it.
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
      *error = LastError(nullptr);
      return nullptr;
    }
    return std::make_unique<OiioReader>(std::move(in));
  }

  // Every format OpenImageIO has a writer for: Write names the ones it has not.
  bool CanWrite(const std::string&, const WriteSpec&, bool) const override { return true; }

  bool Write(const std::string& format, const WriteSpec& spec, const std::string& path,
             std::string* memory, std::string* error) override {
    const std::string name = memory ? "image." + format : path;
    auto out = OIIO::ImageOutput::create(memory ? name : "image." + format);
    if (!out) {
      *error = "no image format for this extension (" + OIIO::geterror() + ")";
      return false;
    }
    if (memory) {
      if (!out->supports("ioproxy")) {
        *error = "cannot encode '" + format + "' images in memory";
        return false;
      }
      std::vector<unsigned char> bytes;
      OIIO::Filesystem::IOVecOutput vec(bytes);
      if (!EncodeInto(out.get(), name, &vec, spec)) {
        *error = out->geterror();
        return false;
      }
      memory->assign(bytes.begin(), bytes.end());
      return true;
    }
    // Writers that take an I/O proxy write through one that sees every failed write (errno).
    std::unique_ptr<FILE, int (*)(FILE*)> f(nullptr, std::fclose);
    std::unique_ptr<CheckedFileOutput> proxy;
    if (out->supports("ioproxy")) {
      f.reset(std::fopen(path.c_str(), "wb"));
      if (!f) {
        *error = std::string("cannot create it: ") + std::strerror(errno);
        return false;
      }
      proxy = std::make_unique<CheckedFileOutput>(f.get());
    }
    const bool ok = EncodeInto(out.get(), path, proxy.get(), spec);
    if (proxy && proxy->error() != 0) {
      *error = std::strerror(proxy->error());
      return false;
    }
    if (!ok) {
      *error = out->geterror();
      return false;
    }
    return !f || FlushAndClose(f.release(), error);
  }
};

}  // namespace
}  // namespace matfit::codec

extern "C" __attribute__((visibility("default"))) matfit::codec::Backend* matfit_oiio_backend() {
  static matfit::codec::OiioBackend backend;
  return &backend;
}
