#include "core/image_io.h"

#include <algorithm>
#include <cctype>
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
#include "core/check.h"
#include "core/image_codec.h"
#include "core/path_util.h"
#include "core/simd_clones.h"
#include "core/version.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

// Decides the transfer function of a file being read.
ColorEncoding ChooseEncoding(const codec::Header& h, const ImageReadOptions& opt,
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
  const std::string& cs = h.color_space;
  if (!cs.empty()) {
    *reason = "file metadata (" + cs + ")";
    if (cs == "Linear" || cs == "linear" || cs == "scene_linear") return {};
    if (cs == "sRGB") return {TransferFunction::kSrgb, 1.0f};
    if (cs.rfind("Gamma", 0) == 0) {
      const float g = h.gamma;
      if (g > 0.0f && std::isfinite(g)) {
        if (std::abs(g - 1.0f) < 1e-3f) return {};
        return {TransferFunction::kGamma, g};
      }
    }
  }
  if (h.sample == codec::Sample::kUint8) {
    *reason = "8-bit default (sRGB)";
    return {TransferFunction::kSrgb, 1.0f};
  }
  *reason = "default for high bit depth (linear)";
  return {};
}

// Interleaved codes (F per pixel) → planar codes of the first K channels; returns the number of
// pixels with a kept channel at the maximum code. A fixed layout, so that the compiler turns
// the strided loads into vector shuffles (core/CMakeLists.txt: GCC's dynamic vector cost model
// for this file; 8-bit RGB: 20× the byte-by-byte loop, 0.02 ns per sample); the count is kept
// per block of 256 pixels in 32 bits (no widening per pixel).
template <typename T, int F, int K>
MATFIT_CLONES_V4 int64_t SplitFixed(const T* __restrict raw, int64_t n, T* __restrict d0,
                                    T* __restrict d1, T* __restrict d2) {
  static_assert(K == 1 || K == 3);
  constexpr T kMax = T(~T(0));
  // Pixel q: its kept codes stored, 1 when one of them is at the maximum.
  auto split = [&](int64_t q) __attribute__((always_inline)) {
    const T a = raw[F * q];
    d0[q] = a;
    if constexpr (K == 1) {
      return a == kMax ? 1u : 0u;
    } else {
      const T b = raw[F * q + 1], c = raw[F * q + 2];
      d1[q] = b, d2[q] = c;
      return (a == kMax || b == kMax || c == kMax) ? 1u : 0u;
    }
  };
  int64_t sat = 0, p = 0;
  for (; p + 256 <= n; p += 256) {
    uint32_t block = 0;
    for (int k = 0; k < 256; ++k) block += split(p + k);
    sat += block;
  }
  for (; p < n; ++p) sat += split(p);
  return sat;
}

// The same for any layout (data maps keep every channel): one sample at a time.
template <typename T>
int64_t SplitAny(const T* raw, int64_t n, int file_ch, int keep_ch, T* const* planes) {
  constexpr T kMax = T(~T(0));
  int64_t sat = 0;
  for (int64_t p = 0; p < n; ++p) {
    bool clipped = false;
    for (int c = 0; c < keep_ch; ++c) {
      const T code = raw[p * file_ch + c];
      clipped |= (code == kMax);
      planes[c][p] = code;
    }
    sat += clipped;
  }
  return sat;
}

// Splits n interleaved pixels of file_ch codes into the planes of their first keep_ch channels
// (planes[c]: n codes); returns the number of pixels with a kept channel at the maximum code.
template <typename T>
int64_t SplitChannels(const T* raw, int64_t n, int file_ch, int keep_ch, T* const* planes) {
  if (keep_ch == 1 && file_ch == 1) return SplitFixed<T, 1, 1>(raw, n, planes[0], nullptr, nullptr);
  if (keep_ch == 1 && file_ch == 2) return SplitFixed<T, 2, 1>(raw, n, planes[0], nullptr, nullptr);
  if (keep_ch == 3 && file_ch == 3)
    return SplitFixed<T, 3, 3>(raw, n, planes[0], planes[1], planes[2]);
  if (keep_ch == 3 && file_ch == 4)
    return SplitFixed<T, 4, 3>(raw, n, planes[0], planes[1], planes[2]);
  return SplitAny(raw, n, file_ch, keep_ch, planes);
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
                   std::unique_ptr<codec::Reader>* in) {
  std::error_code ec;
  const std::string shown = DatasetRelative(path, options.confine_to);
  auto real = ResolveInDataset(path, options.confine_to);
  if (!real.ok()) return Status(real.status().code(), "image " + real.status().message());
  if (!fs::is_regular_file(*real, ec)) return NotFound("image file '" + shown + "' does not exist");
  MATFIT_RETURN_IF_ERROR(CheckPngDeclaredSize(*real, shown));
  std::string error;
  *in = codec::OpenAny(*real, &error);
  if (!*in) {
    std::replace(error.begin(), error.end(), '\n', ' ');  // one line: decoders append newlines
    return DataError("cannot open image '" + shown + "': " + error);
  }
  const codec::Header& h = (*in)->header();
  if (h.width <= 0 || h.height <= 0 || h.channels <= 0 || h.volume)
    return DataError("image '" + shown + "' has an unsupported size or layout");
  // Refuse absurd headers before allocating (a corrupt or hostile file must not exhaust memory).
  constexpr int64_t kMaxSamples = int64_t(1) << 30;  // 4 GiB of float32
  if (int64_t(h.width) * h.height * std::max(1, h.channels) > kMaxSamples)
    return DataError("image '" + shown + "' claims " + std::to_string(h.width) + "x" +
                     std::to_string(h.height) + "x" + std::to_string(h.channels) +
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
  std::unique_ptr<codec::Reader> in;
  MATFIT_RETURN_IF_ERROR(OpenChecked(path, options, &in));
  const codec::Header& f = in->header();
  ImageHeader h;
  h.width = f.width, h.height = f.height, h.file_channels = f.channels;
  h.channels = options.all_channels ? f.channels : (f.channels >= 3 ? 3 : 1);
  h.type = f.sample == codec::Sample::kUint8    ? SampleType::kUint8
           : f.sample == codec::Sample::kUint16 ? SampleType::kUint16
                                                : SampleType::kFloat32;
  return h;
}

namespace {

// An image file opened for decoding: its reader, the rows and columns asked for (checked to lie
// inside it), the channels kept and whether its alpha channel makes the mask.
struct OpenImage {
  std::unique_ptr<codec::Reader> in;
  ImageFileInfo* fi = nullptr;  // what reading finds out: the caller's, or `own`
  ImageFileInfo own;
  std::string shown;  // the name errors give
  int file_ch = 0, keep_ch = 0;
  int row0 = 0, rows = 0, col0 = 0, cols = 0;
  bool want_alpha = false;
  int64_t pixels() const { return int64_t(cols) * rows; }
};

// Opens `path` (OpenChecked), resolves the region and the channels kept, and fills the file's
// channel count and encoding into *info (or o->own when info is null): o->fi.
Status OpenForDecode(const std::string& path, const ImageReadOptions& options, ImageFileInfo* info,
                     OpenImage* o) {
  ImageFileInfo* fi = o->fi = info ? info : &o->own;
  MATFIT_RETURN_IF_ERROR(OpenChecked(path, options, &o->in));
  const codec::Header& h = o->in->header();
  o->shown = DatasetRelative(path, options.confine_to);
  o->file_ch = h.channels;
  // grey(+alpha) → 1, RGB(A) → 3; data maps keep everything.
  o->keep_ch = options.all_channels ? o->file_ch : (o->file_ch >= 3 ? 3 : 1);
  *fi = {};
  fi->file_channels = o->file_ch;
  fi->encoding = ChooseEncoding(h, options, &fi->encoding_reason);
  // The rows and columns asked for (count 0: all); each range must lie inside the image.
  auto range = [&](int first, int count, int size, const char* what, int* b, int* n) -> Status {
    *b = count > 0 ? first : 0, *n = count > 0 ? count : size;
    if (*b >= 0 && *b + *n <= size) return Status::Ok();
    return DataError("image '" + o->shown + "' has " + std::to_string(size) + " " + what + "; " +
                     what + " " + std::to_string(*b) + ".." + std::to_string(*b + *n - 1) +
                     " were asked for: all images of a stack must have the same size");
  };
  MATFIT_RETURN_IF_ERROR(range(options.row0, options.rows, h.height, "rows", &o->row0, &o->rows));
  MATFIT_RETURN_IF_ERROR(range(options.col0, options.cols, h.width, "columns", &o->col0, &o->cols));
  // The channel after the kept ones is alpha (grey+alpha, RGBA).
  o->want_alpha = options.alpha_mask && !options.all_channels &&
                  (o->file_ch == 2 || o->file_ch == 4) && o->file_ch == o->keep_ch + 1;
  return Status::Ok();
}

// Decodes the region's rows, interleaved, into *raw; a column crop keeps [col0, col0 + cols) of
// each row, in place. False when the decoder fails (in->error() says why).
template <typename T>
bool DecodeRegion(OpenImage& o, std::vector<T>* raw) {
  const int width = o.in->header().width;
  raw->resize(size_t(width) * o.rows * o.file_ch);
  if (!o.in->ReadRows(o.row0, o.row0 + o.rows, raw->data())) return false;
  if (o.cols != width) {
    T* d = raw->data();
    for (int r = 0; r < o.rows; ++r)
      std::memmove(d + size_t(r) * o.cols * o.file_ch, d + (size_t(r) * width + o.col0) * o.file_ch,
                   sizeof(T) * size_t(o.cols) * o.file_ch);
    raw->resize(size_t(o.pixels()) * o.file_ch);
  }
  return true;
}

// The integer codes of a decoded region split into planes, the saturation count and (with
// want_alpha) the alpha mask into *fi.
template <typename T>
void StoreCodes(const OpenImage& o, const std::vector<T>& raw, T* const* planes,
                ImageFileInfo* fi) {
  const int64_t n = o.pixels();
  if (o.want_alpha) fi->alpha_mask.resize(size_t(n));  // may throw: before a plane is written
  fi->saturated_pixels = SplitChannels(raw.data(), n, o.file_ch, o.keep_ch, planes);
  if (o.want_alpha) {
    constexpr T kHalf = T(~T(0)) / 2;
    for (int64_t p = 0; p < n; ++p) fi->alpha_mask[p] = raw[p * o.file_ch + o.keep_ch] > kHalf;
  }
}

Status DecodeError(const OpenImage& o) {
  std::string e = o.in->error();
  std::replace(e.begin(), e.end(), '\n', ' ');
  return DataError("cannot decode image '" + o.shown + "' (truncated or corrupt file?): " + e);
}

SampleType SampleOf(const codec::Header& h) {
  return h.sample == codec::Sample::kUint8    ? SampleType::kUint8
         : h.sample == codec::Sample::kUint16 ? SampleType::kUint16
                                              : SampleType::kFloat32;
}

}  // namespace

StatusOr<NativeImage> ReadImageNative(const std::string& path, const ImageReadOptions& options,
                                      ImageFileInfo* info) {
  OpenImage o;
  MATFIT_RETURN_IF_ERROR(OpenForDecode(path, options, info, &o));
  ImageFileInfo& fi = *o.fi;
  const codec::Header& h = o.in->header();
  NativeImage img;
  img.width = o.cols, img.height = o.rows, img.channels = o.keep_ch;
  img.type = SampleOf(h);
  const int64_t n = o.pixels();
  bool ok = false;
  int bytes_per_sample = 4;
  // Integer files keep their codes (native depth): read as T, split into planes.
  auto read_codes = [&](auto* planes, const char* name) {
    using T = typename std::decay_t<decltype(*planes)>::value_type;
    fi.pixel_format = name;
    bytes_per_sample = int(sizeof(T));
    std::vector<T> raw;
    ok = DecodeRegion(o, &raw);
    if (!ok) return;
    planes->resize(size_t(n) * o.keep_ch);
    T* dst[4] = {};
    for (int c = 0; c < o.keep_ch && c < 4; ++c) dst[c] = planes->data() + size_t(c) * n;
    if (o.keep_ch <= 4) {
      StoreCodes(o, raw, dst, &fi);
    } else {  // data maps with more than four channels
      std::vector<T*> many(size_t(o.keep_ch));
      for (int c = 0; c < o.keep_ch; ++c) many[size_t(c)] = planes->data() + size_t(c) * n;
      StoreCodes(o, raw, many.data(), &fi);
    }
  };
  try {  // a header within the caps can still ask for more memory than there is
    if (img.type == SampleType::kUint8) {
      read_codes(&img.u8, "uint8");
    } else if (img.type == SampleType::kUint16) {
      read_codes(&img.u16, "uint16");
    } else {
      fi.pixel_format = h.sample == codec::Sample::kHalf ? "half" : "float";
      img.floats = Image(o.cols, o.rows, o.keep_ch);
      std::vector<float> raw;
      ok = DecodeRegion(o, &raw);
      if (ok) {
        for (int64_t p = 0; p < n; ++p)
          for (int c = 0; c < o.keep_ch; ++c) {
            const float v = raw[p * o.file_ch + c];
            fi.nonfinite_samples += !std::isfinite(v);
            img.floats.Plane(c)[p] = std::isfinite(v) ? DecodeToLinear(v, fi.encoding) : v;
          }
        if (o.want_alpha) {
          fi.alpha_mask.resize(size_t(n));
          for (int64_t p = 0; p < n; ++p) fi.alpha_mask[p] = raw[p * o.file_ch + o.keep_ch] > 0.5f;
        }
      }
    }
  } catch (const std::bad_alloc&) {
    return OutOfMemory(o.shown, h.width, o.rows, o.file_ch, bytes_per_sample);
  }
  if (!ok) return DecodeError(o);
  return img;
}

StatusOr<bool> ReadImageInto(const std::string& path, const ImageReadOptions& options,
                             const PlaneTarget& target, ImageFileInfo* info, ImageHeader* shape,
                             const std::function<bool(const ImageFileInfo&)>& accept) {
  MATFIT_CHECK(target.type != SampleType::kFloat32 && target.channels >= 1 && target.channels <= 4,
               "ReadImageInto: integer planes of 1 to 4 channels");
  OpenImage o;
  MATFIT_RETURN_IF_ERROR(OpenForDecode(path, options, info, &o));
  ImageFileInfo& fi = *o.fi;
  const codec::Header& h = o.in->header();
  ImageHeader got;
  got.width = o.cols, got.height = o.rows, got.channels = o.keep_ch, got.file_channels = o.file_ch;
  got.type = SampleOf(h);
  if (shape) *shape = got;
  // Nothing is written unless the file is exactly what the planes hold.
  if (got.width != target.width || got.height != target.height || got.channels != target.channels ||
      got.type != target.type || (accept && !accept(fi)))
    return false;
  bool ok = false;
  auto read_codes = [&](auto zero, const char* name) {
    using T = decltype(zero);
    fi.pixel_format = name;
    std::vector<T> raw;
    ok = DecodeRegion(o, &raw);
    T* dst[4] = {};
    for (int c = 0; c < o.keep_ch; ++c) dst[c] = static_cast<T*>(target.planes[c]);
    if (ok) StoreCodes(o, raw, dst, &fi);
  };
  try {
    if (got.type == SampleType::kUint8)
      read_codes(uint8_t{}, "uint8");
    else
      read_codes(uint16_t{}, "uint16");
  } catch (const std::bad_alloc&) {
    return OutOfMemory(o.shown, h.width, o.rows, o.file_ch, int(SampleBytes(got.type)));
  }
  if (!ok) return DecodeError(o);
  return true;
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

std::string Extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  if (!ext.empty()) ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == "jpeg" ? "jpg" : ext == "tiff" ? "tif" : ext;
}

// std::lround(x) for the integer formats' codes x ∈ [0, 65535], without the libm call: the same
// integer (ties away from zero; x − ⌊x⌋ is exact), and 0 for NaN, as the cast of lround's
// LONG_MIN gives.
inline float RoundCode(float x) {
  if (!(x >= 0.5f)) return 0.0f;
  const float i = float(int(x));
  return i + (x - i >= 0.5f ? 1.0f : 0.0f);
}

// Encodes `image` as a `format` file at `path`, or into *memory: quantised as `options` say,
// through the native codecs when they write this format, else OpenImageIO. false with *error.
bool Encode(const Image& image, const std::string& format, const ImageWriteOptions& options,
            const std::string& path, std::string* memory, std::string* error) {
  codec::WriteSpec spec;
  const int ch = image.channels();
  const int W = image.width(), H = image.height();
  spec.width = W, spec.height = H, spec.channels = ch;
  switch (options.format) {
    case PixelFormat::kUint8: spec.sample = codec::Sample::kUint8; break;
    case PixelFormat::kUint16: spec.sample = codec::Sample::kUint16; break;
    case PixelFormat::kHalf: spec.sample = codec::Sample::kHalf; break;
    case PixelFormat::kFloat: spec.sample = codec::Sample::kFloat; break;
  }
  const bool srgb = options.transfer == TransferFunction::kSrgb;
  spec.srgb = srgb;
  spec.compact = options.compact;
  spec.jpeg_quality = options.jpeg_quality;
  // --force replaces only files matfit wrote; this tag is how it knows (core/output_marker.h).
  spec.software = std::string("matfit ") + kMatfitVersion;
  // Quantise ourselves (round to nearest) so that 8-bit sRGB codes are exact. The planes are
  // interleaved a strip of rows at a time, so the encoder's input costs a strip, not a copy of
  // the image.
  spec.strip_rows =
      std::max(1, std::min(H, int((1 << 20) / std::max<int64_t>(1, int64_t(W) * ch))));
  auto encoded = [&](int c, int64_t p) {
    const float v = image.Plane(c)[p];
    // RGBA: the alpha plane stays linear.
    return srgb && !(ch == 4 && c == 3) ? LinearToSrgb(std::clamp(v, 0.0f, 1.0f)) : v;
  };
  // Interleaved samples of rows [y0, y1) into `dst`: codes round(v · max) for the integer
  // formats. Reads only the image: safe from several threads for disjoint rows.
  spec.rows_into = [&](int y0, int y1, void* dst) {
    const int64_t p0 = int64_t(y0) * W, n = int64_t(y1 - y0) * W;
    auto quantise = [&]<typename T>(T* q) {
      const float top = float(std::numeric_limits<T>::max());
      std::vector<uint8_t> codes;
      for (int c = 0; c < ch; ++c) {
        const float* v = image.Plane(c).data() + p0;
        if (sizeof(T) == 1 && srgb && !(ch == 4 && c == 3)) {
          // LinearToSrgb8Batch is round(255 · LinearToSrgb(clamp(v))) exactly, without a pow.
          codes.resize(size_t(n));
          LinearToSrgb8Batch(v, 1.0f, int(n), codes.data());
          for (int64_t p = 0; p < n; ++p) q[p * ch + c] = T(codes[size_t(p)]);
          continue;
        }
        for (int64_t p = 0; p < n; ++p)
          q[p * ch + c] = T(RoundCode(std::clamp(encoded(c, p0 + p), 0.0f, 1.0f) * top));
      }
    };
    if (options.format == PixelFormat::kUint8) return quantise(static_cast<uint8_t*>(dst));
    if (options.format == PixelFormat::kUint16) return quantise(static_cast<uint16_t*>(dst));
    float* f = static_cast<float*>(dst);
    for (int c = 0; c < ch; ++c)
      for (int64_t p = 0; p < n; ++p) f[p * ch + c] = encoded(c, p0 + p);
  };
  // The same a strip at a time into one buffer, for the encoders that take rows in order.
  std::vector<unsigned char> strip;
  spec.rows = [&](int y0, int y1) -> const void* {
    const size_t bytes = options.format == PixelFormat::kUint8    ? 1
                         : options.format == PixelFormat::kUint16 ? 2
                                                                  : 4;
    strip.resize(size_t(y1 - y0) * size_t(W) * size_t(ch) * bytes);
    spec.rows_into(y0, y1, strip.data());
    return strip.data();
  };
  codec::Backend* backend = &codec::Native();
  if (!backend->CanWrite(format, spec, memory != nullptr)) {
    backend = codec::OpenImageIo(error);
    if (!backend) return false;
  }
  return backend->Write(format, spec, path, memory, error);
}

}  // namespace

Status WriteImage(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  if (image.empty()) return InvalidArgument("refusing to write empty image '" + path + "'");
  const std::string format = Extension(path);
  if (format.empty())
    return InvalidArgument("cannot write '" + path +
                           "': no image format for a file without an extension (use .png, "
                           ".exr, .jpg, .tif, ...)");
  AtomicFile file(path);
  std::string error;
  if (!Encode(image, format, options, file.temp_path(), nullptr, &error))
    return IoError("writing '" + path + "' failed: " + error);
  return file.Commit();
}

StatusOr<std::string> EncodeImage(const Image& image, const std::string& format,
                                  const ImageWriteOptions& options) {
  if (image.empty()) return InvalidArgument("refusing to encode an empty image");
  std::string bytes, error;
  if (!Encode(image, format, options, "", &bytes, &error))
    return IoError("encoding a " + format + " image failed: " + error);
  return bytes;
}

}  // namespace matfit
