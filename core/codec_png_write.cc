// PNG writer: IHDR, sRGB (sRGB) or gAMA 1.0 (linear), tEXt "oiio:ColorSpace" and "Software",
// IDAT, IEND — the chunks libpng wrote for matfit before — with rows unfiltered (filter type 0).
//
// The image data (each row: a filter byte 0, then its samples, 16-bit ones big-endian) is
// deflated in strips of about kStripBytes, the strips in parallel (pigz's scheme): each strip is
// a raw deflate stream of its own (no back-reference into the strip before) that ends in a sync
// flush — an empty stored block, so the next strip starts on a byte boundary — and the last in
// the final block. Concatenated between the zlib header and the Adler-32 of all the data
// (adler32_combine of the strips'), they are one valid zlib stream. Strips are cut by size, not
// by thread count, so the file's bytes are the same for any thread count; they are encoded in
// waves of kWave strips and written in order, so memory stays a few strips whatever the image.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/codec_file.h"
#include "core/codec_native.h"
#include "core/parallel.h"

namespace matfit::codec {
namespace {

constexpr size_t kStripBytes = size_t(1) << 17;  // raw bytes a strip aims at (filter bytes too)
constexpr int kWave = 8;                         // strips encoded at once

using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

// Where encoded bytes go: a FILE (first errno kept) or memory.
class Out {
 public:
  Out(std::FILE* f, std::string* memory) : f_(f), memory_(memory) {}
  void Put(std::string_view bytes) {
    if (memory_) {
      memory_->append(bytes);
    } else if (error_ == 0 && std::fwrite(bytes.data(), 1, bytes.size(), f_) != bytes.size()) {
      error_ = errno != 0 ? errno : EIO;
    }
  }
  // length, type, data, CRC-32 over type and data.
  void Chunk(const char type[4], std::string_view data) {
    unsigned char head[8];
    Be32(uint32_t(data.size()), head);
    std::memcpy(head + 4, type, 4);
    uLong crc = crc32(0, head + 4, 4);
    // (A null buffer would return crc32's initial value: an empty chunk adds nothing.)
    if (!data.empty())
      crc = crc32(crc, reinterpret_cast<const Bytef*>(data.data()), uInt(data.size()));
    unsigned char tail[4];
    Be32(uint32_t(crc), tail);
    Put({reinterpret_cast<const char*>(head), 8});
    Put(data);
    Put({reinterpret_cast<const char*>(tail), 4});
  }
  int error() const { return error_; }

  static void Be32(uint32_t v, unsigned char* p) {
    p[0] = uint8_t(v >> 24), p[1] = uint8_t(v >> 16), p[2] = uint8_t(v >> 8), p[3] = uint8_t(v);
  }

 private:
  std::FILE* f_;
  std::string* memory_;
  int error_ = 0;
};

// One strip of rows [y0, y1): its raw bytes deflated (a raw stream ending in a sync flush, or,
// for the last strip, the final block), their Adler-32 and length.
struct Strip {
  std::string z;
  uLong adler = 1;
  size_t raw_bytes = 0;
  bool ok = true;
};

bool DeflateStrip(const WriteSpec& w, int y0, int y1, bool last, Strip* out) {
  const int bytes = w.sample == Sample::kUint16 ? 2 : 1;
  const size_t row_bytes = size_t(w.width) * size_t(w.channels) * size_t(bytes);
  const size_t rows = size_t(y1 - y0);
  std::vector<unsigned char> samples(rows * row_bytes), raw(rows * (row_bytes + 1));
  w.rows_into(y0, y1, samples.data());
  for (size_t r = 0; r < rows; ++r) {
    unsigned char* dst = raw.data() + r * (row_bytes + 1);
    const unsigned char* src = samples.data() + r * row_bytes;
    dst[0] = 0;  // filter type None
    if (bytes == 1) {
      std::memcpy(dst + 1, src, row_bytes);
    } else {  // host order → big-endian
      static_assert(std::endian::native == std::endian::little, "16-bit codes are swapped");
      for (size_t k = 0; k < row_bytes; k += 2) dst[1 + k] = src[k + 1], dst[2 + k] = src[k];
    }
  }
  out->raw_bytes = raw.size();
  out->adler = adler32(adler32(0, nullptr, 0), raw.data(), uInt(raw.size()));
  z_stream z = {};
  // Raw deflate (negative window bits): the zlib header and trailer are written once, around
  // every strip. Level 1, or 6 for compact maps; libpng's memory level (8) and strategy.
  if (deflateInit2(&z, w.compact ? 6 : 1, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    return false;
  out->z.resize(deflateBound(&z, uLong(raw.size())) + 64);
  z.next_in = raw.data(), z.avail_in = uInt(raw.size());
  z.next_out = reinterpret_cast<Bytef*>(out->z.data()), z.avail_out = uInt(out->z.size());
  const int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
  // A sync flush is complete only with room left over (zlib: keep more than 6 bytes free).
  const bool done = last ? rc == Z_STREAM_END : rc == Z_OK && z.avail_in == 0 && z.avail_out > 6;
  out->z.resize(out->z.size() - z.avail_out);
  deflateEnd(&z);
  return done;
}

}  // namespace

bool WritePng(const WriteSpec& spec, const std::string& path, std::string* memory,
              std::string* error) {
  if ((spec.channels != 1 && spec.channels != 3) ||
      (spec.sample != Sample::kUint8 && spec.sample != Sample::kUint16)) {
    *error = "the native PNG writer takes 1 or 3 channels of 8 or 16 bits";
    return false;
  }
  // libpng (which reads these files back) refuses more than 1,000,000 pixels a side.
  constexpr int kMaxSide = 1000000;
  if (spec.width <= 0 || spec.height <= 0 || spec.width > kMaxSide || spec.height > kMaxSide) {
    *error = "a PNG of " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
             " cannot be written: 1 to 1000000 pixels a side (write an .exr instead)";
    return false;
  }
  if (!spec.rows_into) {
    *error = "the native PNG writer needs WriteSpec::rows_into";
    return false;
  }
  FilePtr f(nullptr, std::fclose);
  if (memory) {
    memory->clear();
  } else {
    f.reset(std::fopen(path.c_str(), "wb"));
    if (!f) {
      *error = std::string("cannot create it: ") + std::strerror(errno);
      return false;
    }
  }
  Out out(f.get(), memory);
  out.Put({"\x89PNG\r\n\x1a\n", 8});
  const int bytes = spec.sample == Sample::kUint16 ? 2 : 1;
  unsigned char ihdr[13];
  Out::Be32(uint32_t(spec.width), ihdr), Out::Be32(uint32_t(spec.height), ihdr + 4);
  ihdr[8] = uint8_t(8 * bytes);          // bit depth
  ihdr[9] = spec.channels == 1 ? 0 : 2;  // colour type: grey, RGB
  ihdr[10] = ihdr[11] = ihdr[12] = 0;    // deflate, adaptive filtering, no interlace
  out.Chunk("IHDR", {reinterpret_cast<const char*>(ihdr), 13});
  if (spec.srgb) {
    out.Chunk("sRGB", {"\0", 1});  // rendering intent: perceptual
  } else {
    unsigned char gamma[4];
    Out::Be32(100000, gamma);  // gAMA 1.0 (×100000)
    out.Chunk("gAMA", {reinterpret_cast<const char*>(gamma), 4});
  }
  out.Chunk("tEXt", std::string("oiio:ColorSpace") + '\0' + (spec.srgb ? "sRGB" : "Linear"));
  out.Chunk("tEXt", std::string("Software") + '\0' + spec.software);

  const size_t row_bytes = size_t(spec.width) * size_t(spec.channels) * size_t(bytes) + 1;
  const int strip_rows = int(std::clamp<size_t>(kStripBytes / row_bytes, 1, size_t(spec.height)));
  const int strips = (spec.height + strip_rows - 1) / strip_rows;
  // The zlib header (deflate with a 32 KiB window; FLEVEL "fastest" for level 1, "default" for
  // 6) opens the first IDAT, the Adler-32 of all the data closes the last.
  std::string idat = spec.compact ? std::string("\x78\x9c", 2) : std::string("\x78\x01", 2);
  uLong adler = adler32(0, nullptr, 0);
  std::vector<Strip> wave(kWave);
  for (int s0 = 0; s0 < strips && out.error() == 0; s0 += kWave) {
    const int s1 = std::min(strips, s0 + kWave);
    ParallelFor(s0, s1, [&](int64_t a, int64_t b) {
      for (int64_t s = a; s < b; ++s) {
        const int y0 = int(s) * strip_rows, y1 = std::min(spec.height, y0 + strip_rows);
        Strip& st = wave[size_t(s - s0)];
        st.ok = DeflateStrip(spec, y0, y1, s + 1 == strips, &st);
      }
    });
    for (int s = s0; s < s1; ++s) {
      const Strip& st = wave[size_t(s - s0)];
      if (!st.ok) {
        *error = "zlib failed to deflate rows of the image";
        return false;
      }
      adler = adler32_combine(adler, st.adler, z_off_t(st.raw_bytes));
      idat += st.z;
      if (s + 1 == strips) {
        unsigned char trailer[4];
        Out::Be32(uint32_t(adler), trailer);
        idat.append(reinterpret_cast<const char*>(trailer), 4);
      }
      out.Chunk("IDAT", idat);
      idat.clear();
    }
  }
  out.Chunk("IEND", {});
  if (out.error() != 0) {
    *error = std::strerror(out.error());
    return false;
  }
  return !f || FlushAndClose(f.release(), error);
}

}  // namespace matfit::codec
