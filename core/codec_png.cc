// PNG through libpng, read as OpenImageIO 2.4 reads it: 8/16-bit grey, grey+alpha, RGB, RGBA
// (palette, < 8-bit and tRNS files are declined: OpenImageIO expands them); colour space from
// the sRGB chunk ("sRGB") or gAMA ("linear" / "Gamma<g>", g = 1/gAMA rounded to 0.01); the
// Software text chunk. The writer is core/codec_png_write.cc.
#include <png.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/codec_file.h"
#include "core/codec_native.h"

namespace matfit::codec {
namespace {

struct ErrorState {
  char message[256] = {};
};

[[noreturn]] void OnError(png_structp png, png_const_charp msg) {
  auto* e = static_cast<ErrorState*>(png_get_error_ptr(png));
  std::snprintf(e->message, sizeof e->message, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp) {}  // ancillary-chunk trouble: not printed

using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

class PngReader : public Reader {
 public:
  explicit PngReader(FilePtr f) : f_(std::move(f)) {}
  ~PngReader() override {
    if (png_) png_destroy_read_struct(&png_, info_ ? &info_ : nullptr, nullptr);
  }

  bool OpenHeader(bool* declined) {
    *declined = false;
    png_ = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err_, OnError, OnWarning);
    if (!png_) return Fail("cannot create a PNG reader");
    info_ = png_create_info_struct(png_);
    if (!info_) return Fail("cannot create a PNG reader");
    if (setjmp(png_jmpbuf(png_))) return false;
    png_init_io(png_, f_.get());
    png_read_info(png_, info_);
    const int depth = png_get_bit_depth(png_, info_);
    const int type = png_get_color_type(png_, info_);
    if ((depth != 8 && depth != 16) ||
        (type != PNG_COLOR_TYPE_GRAY && type != PNG_COLOR_TYPE_RGB) ||
        png_get_valid(png_, info_, PNG_INFO_tRNS)) {
      *declined = true;
      return false;
    }
    h_.width = int(png_get_image_width(png_, info_));
    h_.height = int(png_get_image_height(png_, info_));
    h_.channels = int(png_get_channels(png_, info_));
    h_.sample = depth == 16 ? Sample::kUint16 : Sample::kUint8;
    double gamma = 0.0;
    if (png_get_gAMA(png_, info_, &gamma) && gamma > 0.0) {
      // 1/gAMA to the nearest hundredth (2.2, not 2.19998), as OpenImageIO reports it.
      const float g = std::round(100.0f * float(1.0 / gamma)) / 100.0f;
      h_.gamma = g;
      char name[32];
      std::snprintf(name, sizeof name, "Gamma%.2g", double(g));
      h_.color_space = g == 1.0f ? "linear" : name;
    }
    if (png_get_valid(png_, info_, PNG_INFO_sRGB)) h_.color_space = "sRGB";
    png_textp text = nullptr;
    int n_text = 0;
    png_get_text(png_, info_, &text, &n_text);
    for (int i = 0; i < n_text; ++i) {
      if (!text[i].key || !text[i].text) continue;
      if (std::strcmp(text[i].key, "Software") == 0) h_.software = text[i].text;
      // OpenImageIO's own tag (it writes one) wins over the chunks, as it does there.
      if (std::strcmp(text[i].key, "oiio:ColorSpace") == 0) h_.color_space = text[i].text;
    }
    h_.software_known = true;
    return true;
  }

  const Header& header() const override { return h_; }

  bool ReadRows(int y0, int y1, void* dst) override {
    auto* out = static_cast<png_bytep>(dst);
    const size_t row_bytes =
        size_t(h_.width) * h_.channels * (h_.sample == Sample::kUint16 ? 2 : 1);
    const bool whole = y0 == 0 && y1 == h_.height;
    // Trouble after the last row (a missing IEND, a bad trailing chunk) keeps the image, as
    // OpenImageIO reads such files too.
    if (setjmp(png_jmpbuf(png_))) return pixels_done_;
    if (h_.sample == Sample::kUint16) png_set_swap(png_);  // big-endian file → host order
    const int passes = png_set_interlace_handling(png_);
    png_read_update_info(png_, info_);
    if (passes == 1) {
      // Row by row: the rows above the band go through one scratch row, none below is read.
      skip_.resize(row_bytes);
      for (int y = 0; y < y1; ++y)
        png_read_row(png_, y < y0 ? skip_.data() : out + row_bytes * size_t(y - y0), nullptr);
      pixels_done_ = true;
      if (y1 == h_.height) png_read_end(png_, nullptr);
      return true;
    }
    // Interlaced (Adam7): every pass spans the image, so it is decoded whole.
    if (!whole) skip_.resize(row_bytes * size_t(h_.height));
    png_bytep base = whole ? out : skip_.data();
    rows_.resize(size_t(h_.height));
    for (int y = 0; y < h_.height; ++y) rows_[size_t(y)] = base + row_bytes * size_t(y);
    png_read_image(png_, rows_.data());
    if (!whole) std::memcpy(out, base + row_bytes * size_t(y0), row_bytes * size_t(y1 - y0));
    pixels_done_ = true;
    png_read_end(png_, nullptr);
    return true;
  }

  std::string error() const override {
    return err_.message[0] ? std::string(err_.message) : "unknown PNG error";
  }

 private:
  bool Fail(const char* why) {
    std::snprintf(err_.message, sizeof err_.message, "%s", why);
    return false;
  }

  FilePtr f_;
  png_structp png_ = nullptr;
  png_infop info_ = nullptr;
  ErrorState err_;
  Header h_;
  std::vector<png_bytep> rows_;
  std::vector<png_byte> skip_;         // rows above the band, or a whole interlaced image
  volatile bool pixels_done_ = false;  // read after a longjmp
};

// Walks the chunks (length, type, data, CRC) up to IEND and checks that each one's data fits in
// the file: libpng allocates a text chunk's declared length before reading it, so a few hostile
// bytes could ask for a gigabyte. Leaves `f` at the start.
bool ChunksFit(FILE* f, std::string* error) {
  if (std::fseek(f, 0, SEEK_END) != 0) return true;
  const long size = std::ftell(f);
  long pos = 8;  // the signature
  for (int n = 0; n < 1'000'000 && pos + 8 <= size; ++n) {
    unsigned char h[8];
    if (std::fseek(f, pos, SEEK_SET) != 0 || std::fread(h, 1, 8, f) != 8) break;
    const long length =
        long(uint32_t(h[0]) << 24 | uint32_t(h[1]) << 16 | uint32_t(h[2]) << 8 | uint32_t(h[3]));
    char type[5] = {char(h[4]), char(h[5]), char(h[6]), char(h[7]), 0};
    for (char& c : type)
      if (c && !std::isalpha(static_cast<unsigned char>(c))) c = '?';
    if (length > size - pos - 12) {
      *error = std::string("its '") + type + "' chunk declares " + std::to_string(length) +
               " bytes but only " + std::to_string(std::max(0L, size - pos - 12)) +
               " follow: the file is truncated or corrupt";
      return false;
    }
    if (std::memcmp(type, "IEND", 4) == 0) break;
    pos += 12 + length;
  }
  std::rewind(f);
  return true;
}

}  // namespace

std::unique_ptr<Reader> OpenPng(const std::string& path, std::string* error) {
  FilePtr f(std::fopen(path.c_str(), "rb"), std::fclose);
  if (!f) {
    *error = std::string("cannot open it: ") + std::strerror(errno);
    return nullptr;
  }
  if (!ChunksFit(f.get(), error)) return nullptr;
  auto r = std::make_unique<PngReader>(std::move(f));
  bool declined = false;
  if (r->OpenHeader(&declined)) return r;
  if (!declined) *error = r->error();
  return nullptr;
}

}  // namespace matfit::codec
