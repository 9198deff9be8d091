// Image codecs behind core/image_io (internal to core): one interface, two backends.
//  - Native: JPEG (libjpeg-turbo), PNG (libpng) and OpenEXR through their own libraries, the
//    formats of nearly every dataset and of every fitted pack. Linking them costs ~10 shared
//    libraries.
//  - OpenImageIO for everything else (TGA, TIFF, RAW, HDR, ... and what the native readers
//    decline: CMYK JPEGs, palette PNGs, unusual EXR layouts), loaded with dlopen on first use:
//    its ~260 shared libraries cost every process 0.3 s and ~115 MB before main() when linked
//    (docs/benchmarks.md), so only a process that meets such a file pays for them.
// Both backends report what OpenImageIO reports (same pixels, same colour-space names), so
// image_io decides the same whichever decoded the file (tests/core/image_codec_test.cc).
#pragma once

#include <functional>
#include <memory>
#include <string>

namespace matfit::codec {

enum class Sample { kUint8, kUint16, kHalf, kFloat };

struct Header {
  int width = 0, height = 0, channels = 0;
  bool volume = false;  // a deep or 3-D image (refused by image_io)
  Sample sample = Sample::kUint8;
  // Colour space as OpenImageIO names it ("sRGB", "linear", "Gamma2.2", "Linear"), empty when
  // the file says nothing; gamma > 0 with a "Gamma…" space.
  std::string color_space;
  float gamma = 0.0f;
  std::string software;         // the file's Software tag
  bool software_known = false;  // false: this reader does not look for the tag
};

class Reader {
 public:
  virtual ~Reader() = default;
  virtual const Header& header() const = 0;
  // Rows [y0, y1) (0 ≤ y0 < y1 ≤ height), interleaved: uint8/uint16 codes for integer files,
  // float for half/float ones. false on a decoding error (error() says why). Called at most once
  // (this or Read). EXR and OpenImageIO read only those rows; JPEG skips the rows above y0
  // (Huffman-decoded, no IDCT) and PNG decodes and drops them; neither decodes below y1, except
  // an interlaced PNG, which is decoded whole (docs/scale-out.md).
  virtual bool ReadRows(int y0, int y1, void* dst) = 0;
  // Every pixel.
  bool Read(void* dst) { return ReadRows(0, header().height, dst); }
  virtual std::string error() const = 0;
};

struct WriteSpec {
  int width = 0, height = 0, channels = 0;
  Sample sample = Sample::kUint16;  // the file's samples
  bool srgb = false;                // colour space tag: sRGB, else linear (gamma 1)
  bool compact = false;             // PNG zlib level 6 (else 1); EXR PIZ (else uncompressed)
  std::string software;
  int jpeg_quality = 0;  // JPEG: 1 … 100 with 4:4:4 chroma; 0 = the encoder's default
  int strip_rows = 1;
  // Rows [y0, y1) interleaved: uint8/uint16 codes for integer samples, float otherwise. The
  // pointer stays valid until the next call.
  std::function<const void*(int y0, int y1)> rows;
  // The same samples written to `dst`; callable from several threads at once for disjoint rows
  // (the PNG writer encodes strips in parallel). Optional for the other encoders.
  std::function<void(int y0, int y1, void* dst)> rows_into;
};

class Backend {
 public:
  virtual ~Backend() = default;
  // A reader for the file at `path`; nullptr with *error empty when this backend declines the
  // file (another may read it), nullptr with *error set when it is this backend's format but
  // cannot be opened.
  virtual std::unique_ptr<Reader> Open(const std::string& path, std::string* error) = 0;
  // Whether Write handles `format` (lower-case extension without the dot: "png", "exr", ...)
  // with these samples and channels, to a file or (in_memory) into memory.
  virtual bool CanWrite(const std::string& format, const WriteSpec& spec, bool in_memory) const = 0;
  // Encodes to `path`, or into *memory when memory is not null. false with *error set on
  // failure (a failed write names errno's reason).
  virtual bool Write(const std::string& format, const WriteSpec& spec, const std::string& path,
                     std::string* memory, std::string* error) = 0;
};

// JPEG, PNG and OpenEXR through their own libraries (core/codec_native.cc).
Backend& Native();
// OpenImageIO, loaded on first use (core/codec_oiio_loader.cc); nullptr with *error set when
// the module cannot be loaded.
Backend* OpenImageIo(std::string* error);

// A JPEG held in memory (MJPEG camera frames): nullptr with *error set when it is not one.
std::unique_ptr<Reader> OpenJpegMemory(const unsigned char* bytes, size_t size, std::string* error);

// Reading: the native backend, then OpenImageIO for what it declines.
std::unique_ptr<Reader> OpenAny(const std::string& path, std::string* error);

}  // namespace matfit::codec

// The OpenImageIO module's one entry point (core/codec_oiio.cc).
extern "C" matfit::codec::Backend* matfit_oiio_backend();
