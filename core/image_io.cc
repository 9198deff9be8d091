#include "core/image_io.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <new>
#include <type_traits>
#include <vector>

#include "core/atomic_file.h"
#include "core/path_util.h"
#include "core/version.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

std::string LastOiioError(OIIO::ImageInput* in) {
  std::string e = in ? in->geterror() : std::string();
  if (e.empty()) e = OIIO::geterror();
  if (e.empty()) e = "unknown decoder error";
  // Keep one line: decoders sometimes append newlines.
  std::replace(e.begin(), e.end(), '\n', ' ');
  return e;
}

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

// Decides the transfer function of a file being read.
ColorEncoding ChooseEncoding(const OIIO::ImageSpec& spec, const ImageReadOptions& opt,
                             std::string* reason) {
  auto from_choice = [](ColorSpaceChoice c) {
    return ColorEncoding{
        c == ColorSpaceChoice::kSrgb ? TransferFunction::kSrgb : TransferFunction::kLinear, 1.0f};
  };
  if (opt.color_space != ColorSpaceChoice::kAuto) {
    *reason = "user override";
    return from_choice(opt.color_space);
  }
  if (opt.layout_default != ColorSpaceChoice::kAuto) {
    *reason = "layout default";
    return from_choice(opt.layout_default);
  }
  const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  if (!cs.empty()) {
    *reason = "file metadata (" + cs + ")";
    if (cs == "Linear" || cs == "linear" || cs == "scene_linear") return {};
    if (cs == "sRGB") return {TransferFunction::kSrgb, 1.0f};
    if (cs.rfind("Gamma", 0) == 0) {
      const float g = spec.get_float_attribute("oiio:Gamma", 0.0f);
      if (g > 0.0f && std::isfinite(g)) {
        if (std::abs(g - 1.0f) < 1e-3f) return {};
        return {TransferFunction::kGamma, g};
      }
    }
  }
  if (spec.format.basetype == OIIO::TypeDesc::UINT8) {
    *reason = "8-bit default (sRGB)";
    return {TransferFunction::kSrgb, 1.0f};
  }
  *reason = "default for high bit depth (linear)";
  return {};
}

// Interleaved codes (file_ch per pixel) → planar codes of the first keep_ch channels; counts
// pixels with a kept channel at the maximum code.
template <typename T>
std::vector<T> Deinterleave(const std::vector<T>& raw, int64_t n, int file_ch, int keep_ch,
                            int64_t* saturated) {
  constexpr T kMax = T(~T(0));
  std::vector<T> planes(size_t(n) * keep_ch);
  int64_t sat = 0;
  for (int64_t p = 0; p < n; ++p) {
    bool clipped = false;
    for (int c = 0; c < keep_ch; ++c) {
      const T code = raw[p * file_ch + c];
      clipped |= (code == kMax);
      planes[size_t(c) * n + p] = code;
    }
    sat += clipped;
  }
  *saturated = sat;
  return planes;
}

template <typename T>
void ExpandCodes(const std::vector<T>& codes, const std::vector<float>& lut, Image* out) {
  float* dst = out->data().data();
  for (size_t k = 0; k < codes.size(); ++k) dst[k] = lut[codes[k]];
}

}  // namespace

namespace {

uint32_t Be32(const unsigned char* b) {
  return uint32_t(b[0]) << 24 | uint32_t(b[1]) << 16 | uint32_t(b[2]) << 8 | uint32_t(b[3]);
}

// A PNG's pixel data is deflated, and deflate compresses at most 1032:1 (a 258-byte match in two
// bits). A header that declares more raw bytes than 1032 × the file's size describes data the
// file cannot hold: it is truncated, or its header lies (a decompression bomb's cheap form).
// Refused before anything is allocated. Other formats are left to their decoders.
Status CheckPngDeclaredSize(const std::string& real, const std::string& shown) {
  unsigned char h[29];
  std::ifstream f(real, std::ios::binary);
  if (!f.read(reinterpret_cast<char*>(h), sizeof h)) return Status::Ok();
  if (std::memcmp(h, "\x89PNG\r\n\x1a\n", 8) != 0 || std::memcmp(h + 12, "IHDR", 4) != 0)
    return Status::Ok();
  const uint32_t w = Be32(h + 16), rows = Be32(h + 20);
  const int depth = h[24], type = h[25];
  const int spp = type == 0 ? 1 : type == 2 ? 3 : type == 3 ? 1 : type == 4 ? 2 : type == 6 ? 4 : 0;
  if (spp == 0 || depth == 0) return Status::Ok();  // the decoder explains a bad header
  // Each row: a filter byte and its packed samples (interlaced images need more, never less).
  const double raw = double(rows) * (1.0 + std::ceil(double(w) * spp * depth / 8.0));
  std::error_code ec;
  const auto size = fs::file_size(real, ec);
  if (ec || raw <= 1032.0 * double(size)) return Status::Ok();
  return DataError("image '" + shown + "' declares " + std::to_string(w) + "x" +
                   std::to_string(rows) + " pixels (" + std::to_string(spp) + " sample(s) of " +
                   std::to_string(depth) + " bit(s)), " + std::to_string(int64_t(raw / (1 << 20))) +
                   " MiB of pixel data, but the file " + "has only " + std::to_string(size) +
                   " bytes, too few even at PNG's best compression (1032:1): the file is "
                   "truncated or its header is wrong");
}

// Opens `path` through the dataset sandbox and checks what its header declares before anything
// is allocated: a layout matfit reads, at most 2^30 samples, and (PNG) a file long enough for
// the pixel data it claims.
Status OpenChecked(const std::string& path, const ImageReadOptions& options,
                   std::unique_ptr<OIIO::ImageInput>* in, OIIO::ImageSpec* spec) {
  std::error_code ec;
  const std::string shown = DatasetRelative(path, options.confine_to);
  auto real = ResolveInDataset(path, options.confine_to);
  if (!real.ok()) return Status(real.status().code(), "image " + real.status().message());
  if (!fs::is_regular_file(*real, ec)) return NotFound("image file '" + shown + "' does not exist");
  MATFIT_RETURN_IF_ERROR(CheckPngDeclaredSize(*real, shown));
  *in = OIIO::ImageInput::open(*real);
  if (!*in) return DataError("cannot open image '" + shown + "': " + LastOiioError(nullptr));
  *spec = (*in)->spec();
  if (spec->width <= 0 || spec->height <= 0 || spec->nchannels <= 0 || spec->depth > 1)
    return DataError("image '" + shown + "' has an unsupported size or layout");
  // Refuse absurd headers before allocating (a corrupt or hostile file must not exhaust memory).
  constexpr int64_t kMaxSamples = int64_t(1) << 30;  // 4 GiB of float32
  if (int64_t(spec->width) * spec->height * std::max(1, spec->nchannels) > kMaxSamples)
    return DataError("image '" + shown + "' claims " + std::to_string(spec->width) + "x" +
                     std::to_string(spec->height) + "x" + std::to_string(spec->nchannels) +
                     " samples, more than matfit reads at once (2^30); crop or tile it");
  return Status::Ok();
}

// The message for an allocation that failed while decoding `shown`.
Status OutOfMemory(const std::string& shown, int w, int h, int channels, int bytes_per_sample) {
  const double mib = double(w) * h * channels * bytes_per_sample / double(1 << 20);
  return DataError("image '" + shown + "' declares " + std::to_string(w) + "x" + std::to_string(h) +
                   " pixels with " + std::to_string(channels) + " channel(s) (" +
                   std::to_string(int64_t(mib)) +
                   " MiB to decode) and the memory for it could not be allocated; crop or "
                   "downscale the image, or use a machine with more memory");
}

}  // namespace

StatusOr<ImageHeader> ReadImageHeader(const std::string& path, const ImageReadOptions& options) {
  std::unique_ptr<OIIO::ImageInput> in;
  OIIO::ImageSpec spec;
  MATFIT_RETURN_IF_ERROR(OpenChecked(path, options, &in, &spec));
  ImageHeader h;
  h.width = spec.width, h.height = spec.height, h.file_channels = spec.nchannels;
  h.channels = options.all_channels ? spec.nchannels : (spec.nchannels >= 3 ? 3 : 1);
  const auto base = spec.format.basetype;
  h.type = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8     ? SampleType::kUint8
           : base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16 ? SampleType::kUint16
                                                                             : SampleType::kFloat32;
  return h;
}

StatusOr<NativeImage> ReadImageNative(const std::string& path, const ImageReadOptions& options,
                                      ImageFileInfo* info) {
  std::unique_ptr<OIIO::ImageInput> in;
  OIIO::ImageSpec spec;
  MATFIT_RETURN_IF_ERROR(OpenChecked(path, options, &in, &spec));
  const std::string shown = DatasetRelative(path, options.confine_to);
  const int file_ch = spec.nchannels;
  // grey(+alpha) → 1, RGB(A) → 3; data maps keep everything.
  const int keep_ch = options.all_channels ? file_ch : (file_ch >= 3 ? 3 : 1);
  ImageFileInfo local;
  ImageFileInfo& fi = info ? *info : local;
  fi = {};
  fi.file_channels = file_ch;
  fi.encoding = ChooseEncoding(spec, options, &fi.encoding_reason);

  NativeImage img;
  img.width = spec.width, img.height = spec.height, img.channels = keep_ch;
  const int64_t n = int64_t(spec.width) * spec.height;
  const auto base = spec.format.basetype;
  bool ok = false;
  int bytes_per_sample = 4;
  // Integer files keep their codes (native depth): read as T, split into planes.
  auto read_codes = [&](auto* planes, OIIO::TypeDesc type, SampleType sample, const char* name) {
    using T = typename std::decay_t<decltype(*planes)>::value_type;
    fi.pixel_format = name;
    img.type = sample;
    bytes_per_sample = int(sizeof(T));
    std::vector<T> raw(size_t(n) * file_ch);
    // The file's own type is asked for as "native" (TypeDesc::UNKNOWN): OpenImageIO 2.4 then
    // decodes straight into `raw`, where an explicit type, even the same one, goes through a
    // 64 MiB staging buffer that is mapped, faulted in and unmapped for every image.
    ok = in->read_image(0, 0, 0, file_ch, type == spec.format ? OIIO::TypeDesc::UNKNOWN : type,
                        raw.data());
    if (ok) *planes = Deinterleave(raw, n, file_ch, keep_ch, &fi.saturated_pixels);
  };
  try {  // a header within the caps can still ask for more memory than there is
    if (base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8) {
      read_codes(&img.u8, OIIO::TypeDesc::UINT8, SampleType::kUint8, "uint8");
    } else if (base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16) {
      read_codes(&img.u16, OIIO::TypeDesc::UINT16, SampleType::kUint16, "uint16");
    } else {
      fi.pixel_format = base == OIIO::TypeDesc::HALF ? "half" : "float";
      img.type = SampleType::kFloat32;
      img.floats = Image(spec.width, spec.height, keep_ch);
      std::vector<float> raw(size_t(n) * file_ch);
      const OIIO::TypeDesc want =
          spec.format == OIIO::TypeDesc::FLOAT ? OIIO::TypeDesc::UNKNOWN : OIIO::TypeDesc::FLOAT;
      ok = in->read_image(0, 0, 0, file_ch, want, raw.data());  // native: no staging buffer
      if (ok) {
        for (int64_t p = 0; p < n; ++p)
          for (int c = 0; c < keep_ch; ++c) {
            const float v = raw[p * file_ch + c];
            fi.nonfinite_samples += !std::isfinite(v);
            img.floats.Plane(c)[p] = std::isfinite(v) ? DecodeToLinear(v, fi.encoding) : v;
          }
      }
    }
  } catch (const std::bad_alloc&) {
    return OutOfMemory(shown, spec.width, spec.height, file_ch, bytes_per_sample);
  }
  if (!ok || in->has_error()) {
    return DataError("cannot decode image '" + shown +
                     "' (truncated or corrupt file?): " + LastOiioError(in.get()));
  }
  in->close();
  return img;
}

StatusOr<Image> ReadImage(const std::string& path, const ImageReadOptions& options,
                          ImageFileInfo* info) {
  ImageFileInfo local;
  ImageFileInfo& fi = info ? *info : local;
  auto native = ReadImageNative(path, options, &fi);
  if (!native.ok()) return native.status();
  if (native->type == SampleType::kFloat32) return std::move(native->floats);
  try {
    Image img(native->width, native->height, native->channels);
    if (native->type == SampleType::kUint8)
      ExpandCodes(native->u8, LinearDecodeTable(fi.encoding, 8), &img);
    else
      ExpandCodes(native->u16, LinearDecodeTable(fi.encoding, 16), &img);
    return img;
  } catch (const std::bad_alloc&) {
    return OutOfMemory(DatasetRelative(path, options.confine_to), native->width, native->height,
                       native->channels, 4);
  }
}

Status ReadImageSize(const std::string& path, int* width, int* height, int* channels) {
  auto h = ReadImageHeader(path);
  if (!h.ok()) return h.status();
  *width = h->width;
  *height = h->height;
  *channels = h->channels;
  return Status::Ok();
}

namespace {

// Encodes `image` into `out` (a file named `file_name`, or through `proxy` when given):
// quantised as `options` say; false with out's error when the encoder fails.
bool EncodeInto(OIIO::ImageOutput* out, const std::string& file_name,
                OIIO::Filesystem::IOProxy* proxy, const Image& image,
                const ImageWriteOptions& options) {
  OIIO::TypeDesc type = OIIO::TypeDesc::UINT16;
  switch (options.format) {
    case PixelFormat::kUint8: type = OIIO::TypeDesc::UINT8; break;
    case PixelFormat::kUint16: type = OIIO::TypeDesc::UINT16; break;
    case PixelFormat::kHalf: type = OIIO::TypeDesc::HALF; break;
    case PixelFormat::kFloat: type = OIIO::TypeDesc::FLOAT; break;
  }
  const int ch = image.channels();
  OIIO::ImageSpec spec(image.width(), image.height(), ch, type);
  const bool srgb = options.transfer == TransferFunction::kSrgb;
  if (ch > 4) {
    // Data maps with many planes: EXR sorts channels by name, so name them in numeric order.
    spec.channelnames.clear();
    char name[16];
    for (int c = 0; c < ch; ++c)
      std::snprintf(name, sizeof name, "ch%02d", c), spec.channelnames.push_back(name);
    spec.alpha_channel = -1;
  }
  spec.attribute("oiio:ColorSpace", srgb ? "sRGB" : "Linear");
  // --force replaces only files matfit wrote; this tag is how it knows (core/output_marker.h).
  spec.attribute("Software", std::string("matfit ") + kMatfitVersion);
  if (!srgb) spec.attribute("oiio:Gamma", 1.0f);
  // Float EXR: uncompressed, or (compact) PIZ, the lossless wavelet coder, which on fitted maps
  // is 1.4× faster than OpenEXR's default ZIP and 12 % smaller. PNG: zlib level 1 or 6.
  if (options.format == PixelFormat::kFloat && std::strcmp(out->format_name(), "openexr") == 0)
    spec.attribute("compression", options.compact ? "piz" : "none");
  if (std::strcmp(out->format_name(), "png") == 0)
    spec.attribute("png:compressionLevel", options.compact ? 6 : 1);
  // Quantise ourselves (round to nearest) so that 8-bit sRGB codes are exact. The planes are
  // interleaved a strip of rows at a time, so the encoder's input costs a strip, not a copy of
  // the image.
  const int W = image.width(), H = image.height();
  const int strip_rows =
      std::max(1, std::min(H, int((1 << 20) / std::max<int64_t>(1, int64_t(W) * ch))));
  std::vector<uint8_t> q8;
  std::vector<uint16_t> q16;
  std::vector<float> f32;
  OIIO::TypeDesc buffer_type = type;
  auto encoded = [&](int c, int64_t p) {
    const float v = image.Plane(c)[p];
    // RGBA: the alpha plane stays linear.
    return srgb && !(ch == 4 && c == 3) ? LinearToSrgb(std::clamp(v, 0.0f, 1.0f)) : v;
  };
  // Interleaved samples of rows [y0, y1) in the buffer's type: codes round(v · max) for the
  // integer formats.
  auto interleave = [&](int y0, int y1) -> const void* {
    const int64_t p0 = int64_t(y0) * W, n = int64_t(y1 - y0) * W;
    auto quantise = [&]<typename T>(std::vector<T>& q) -> const void* {
      const float top = float(std::numeric_limits<T>::max());
      q.resize(size_t(n) * ch);
      for (int c = 0; c < ch; ++c)
        for (int64_t p = 0; p < n; ++p)
          q[p * ch + c] = T(std::lround(std::clamp(encoded(c, p0 + p), 0.0f, 1.0f) * top));
      return q.data();
    };
    if (options.format == PixelFormat::kUint8) return quantise(q8);
    if (options.format == PixelFormat::kUint16) return quantise(q16);
    f32.resize(size_t(n) * ch);
    for (int c = 0; c < ch; ++c)
      for (int64_t p = 0; p < n; ++p) f32[p * ch + c] = encoded(c, p0 + p);
    return f32.data();
  };
  if (options.format != PixelFormat::kUint8 && options.format != PixelFormat::kUint16)
    buffer_type = OIIO::TypeDesc::FLOAT;
  if (proxy) out->set_ioproxy(proxy);
  if (!out->open(file_name, spec)) return false;
  bool written = true;
  for (int y0 = 0; y0 < H && written; y0 += strip_rows) {
    const int y1 = std::min(H, y0 + strip_rows);
    written = out->write_scanlines(y0, y1, 0, buffer_type, interleave(y0, y1));
  }
  return out->close() && written;
}

}  // namespace

Status WriteImage(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  if (image.empty()) return InvalidArgument("refusing to write empty image '" + path + "'");
  auto out = OIIO::ImageOutput::create(path);
  if (!out)
    return InvalidArgument("cannot write '" + path + "': no image format for this extension (" +
                           OIIO::geterror() + ")");
  AtomicFile file(path);
  // Writers that take an I/O proxy write through one that sees every failed write (errno).
  std::unique_ptr<FILE, int (*)(FILE*)> f(nullptr, std::fclose);
  std::unique_ptr<CheckedFileOutput> proxy;
  if (out->supports("ioproxy")) {
    f.reset(std::fopen(file.temp_path().c_str(), "wb"));
    if (!f) return IoError("cannot create '" + file.temp_path() + "': " + std::strerror(errno));
    proxy = std::make_unique<CheckedFileOutput>(f.get());
  }
  const auto write_failed = [&](int err) {
    return IoError("writing '" + path + "' failed: " + std::strerror(err));
  };
  const bool ok = EncodeInto(out.get(), file.temp_path(), proxy.get(), image, options);
  if (proxy && proxy->error() != 0) return write_failed(proxy->error());
  if (!ok) return IoError("writing '" + path + "' failed: " + out->geterror());
  if (f) {  // buffered bytes: a full disk shows here
    errno = 0;
    if (std::fflush(f.get()) != 0) return write_failed(errno != 0 ? errno : EIO);
    if (std::fclose(f.release()) != 0) return write_failed(errno != 0 ? errno : EIO);
  }
  return file.Commit();
}

StatusOr<std::string> EncodeImage(const Image& image, const std::string& format,
                                  const ImageWriteOptions& options) {
  if (image.empty()) return InvalidArgument("refusing to encode an empty image");
  const std::string name = "image." + format;
  auto out = OIIO::ImageOutput::create(name);
  if (!out || !out->supports("ioproxy"))
    return InvalidArgument("cannot encode '" + format + "' images in memory");
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput vec(bytes);
  if (!EncodeInto(out.get(), name, &vec, image, options))
    return IoError("encoding a " + format + " image failed: " + out->geterror());
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace matfit
