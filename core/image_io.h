// Image files in and out: JPEG, PNG (8/16-bit) and OpenEXR through their own libraries, every
// other format (TGA, TIFF, RAW, HDR, ...) through OpenImageIO, loaded on first use
// (core/image_codec.h). Reading yields linear float planes; writing encodes linear planes.
// Writes are atomic.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/image.h"
#include "core/sample_type.h"
#include "core/status.h"

namespace matfit {

struct ImageReadOptions {
  // User override of the transfer function; kAuto applies the rules below.
  ColorSpaceChoice color_space = ColorSpaceChoice::kAuto;
  // Used when color_space is kAuto and the layout documents its encoding (DiLiGenT: linear).
  ColorSpaceChoice layout_default = ColorSpaceChoice::kAuto;
  // Data maps (coefficient planes, lobe shapes): keep every channel instead of 1 or 3.
  bool all_channels = false;
  // When set, a file that resolves (symlinks, `..`) outside this folder is refused and never
  // opened (ResolveInDataset): the server confines a job to its dataset.
  std::string confine_to;
  // Only rows [row0, row0 + rows) (rows 0: every row): a rank's band of a distributed stack.
  // The image returned has `rows` rows; saturation and non-finite counts are the band's.
  int row0 = 0, rows = 0;
  // Only columns [col0, col0 + cols) (cols 0: every column): a crop. The image returned has
  // `cols` columns; counts are the crop's.
  int col0 = 0, cols = 0;
  // Files with an alpha channel (grey+alpha, RGBA): fill ImageFileInfo::alpha_mask.
  bool alpha_mask = false;
};

// What reading a file found out, for `matfit info` and warnings.
struct ImageFileInfo {
  int file_channels = 0;          // channels in the file (alpha is dropped on read)
  std::string pixel_format;       // "uint8", "uint16", "half", "float"
  ColorEncoding encoding;         // transfer function used to linearise
  std::string encoding_reason;    // "user override", "layout default", "file metadata", ...
  int64_t saturated_pixels = 0;   // integer formats: pixels with a channel at the max code
  int64_t nonfinite_samples = 0;  // float formats: NaN / Inf samples
  // With ImageReadOptions::alpha_mask and a file with alpha: 1 where alpha > half its range
  // (width × height of the image returned); otherwise empty.
  std::vector<uint8_t> alpha_mask;
};

// Reads `path` as linear float: 1 channel for grey files, 3 for colour; alpha dropped.
// Transfer function (first match): options.color_space; options.layout_default; the file's
// colour-space metadata (e.g. PNG gAMA/sRGB chunks as OIIO reports them); 8-bit → sRGB;
// otherwise linear. Integer codes map to [0, 1].
StatusOr<Image> ReadImage(const std::string& path, const ImageReadOptions& options = {},
                          ImageFileInfo* info = nullptr);

// One image at its file's own depth, planar [channel][row][col], channels as ReadImage keeps
// them: integer files (8/16-bit) as their codes, whose linear values are
// LinearDecodeTable(info.encoding, 8 or 16)[code]; half/float files as linear float (`floats`).
struct NativeImage {
  int width = 0, height = 0, channels = 0;
  SampleType type = SampleType::kFloat32;
  std::vector<uint8_t> u8;    // kUint8: channels × height × width codes
  std::vector<uint16_t> u16;  // kUint16
  Image floats;               // kFloat32
};

// Reads `path` like ReadImage but keeps integer codes: ReadImage(path) is this image with every
// code replaced by its table value (same transfer function, same saturation count).
StatusOr<NativeImage> ReadImageNative(const std::string& path, const ImageReadOptions& options = {},
                                      ImageFileInfo* info = nullptr);

// What an image's header declares, read without decoding a pixel.
struct ImageHeader {
  int width = 0, height = 0;
  int channels = 0;       // as ReadImage keeps them (1 or 3; all with all_channels)
  int file_channels = 0;  // in the file
  SampleType type = SampleType::kFloat32;  // as ReadImageNative would hold the samples
};

// The planes one image of an integer stack decodes into (ReadImageInto).
struct PlaneTarget {
  int width = 0, height = 0, channels = 0;  // as ReadImageNative would return the image
  SampleType type = SampleType::kUint8;     // kUint8 or kUint16
  void* planes[4] = {};                     // channel c: width × height codes of `type`
};

// ReadImageNative into the caller's planes, without planes of its own: true when the file's
// region, kept channels and sample type are the target's and `accept` (if set) takes its
// ImageFileInfo as known before decoding (the transfer function); the planes and the info's
// counts and mask are then ReadImageNative's. False leaves the planes untouched: *shape says
// what the file holds. Errors as ReadImageNative's (the planes untouched too).
StatusOr<bool> ReadImageInto(const std::string& path, const ImageReadOptions& options,
                             const PlaneTarget& target, ImageFileInfo* info, ImageHeader* shape,
                             const std::function<bool(const ImageFileInfo&)>& accept = {});

// Reads only the header, with ReadImageNative's checks: options.confine_to, a size and layout
// matfit reads, at most 2^30 samples, and for PNG a file long enough for the pixel data its
// header declares (a lying header is refused with the file and the declared size). Errors from
// reading name the file (relative to confine_to when set); an allocation that fails while
// decoding is an error naming the file and its declared size, never std::bad_alloc.
StatusOr<ImageHeader> ReadImageHeader(const std::string& path,
                                      const ImageReadOptions& options = {});

// Reads only the header: size and channel count as ReadImage would return them.
Status ReadImageSize(const std::string& path, int* width, int* height, int* channels);

enum class PixelFormat { kUint8, kUint16, kHalf, kFloat };

struct ImageWriteOptions {
  PixelFormat format = PixelFormat::kUint16;
  // kSrgb encodes linear values with the sRGB curve (albedo maps, 8-bit datasets);
  // kLinear stores values as they are (normals, data maps, 16-bit datasets, EXR).
  TransferFunction transfer = TransferFunction::kLinear;
  // Encoding effort (both lossless): fast = PNG at zlib level 1 and uncompressed float EXR;
  // compact = PNG at zlib level 6 and PIZ EXR: a fitted pack's maps 13 % (lambert) to 31 %
  // (hsh3) smaller (noisy floats barely compress) for about 3× the encode time
  // (docs/benchmarks.md).
  bool compact = false;
  // JPEG only: quality 1 … 100 with full-resolution chroma (4:4:4); 0 = the encoder's default.
  int jpeg_quality = 0;
};

// Writes `image` (values clamped to [0, 1] for integer formats) to `path`, format from the
// extension. Atomic: the data goes to a temporary file in the same folder, renamed on success.
Status WriteImage(const std::string& path, const Image& image, const ImageWriteOptions& options);

// `image` encoded as a file of `format` ("png", "exr", ...) in memory, quantised like WriteImage.
StatusOr<std::string> EncodeImage(const Image& image, const std::string& format,
                                  const ImageWriteOptions& options);

}  // namespace matfit
