// JPEG reading through libjpeg(-turbo), as OpenImageIO 2.4 decodes it: libjpeg's default
// decoder settings (islow IDCT, fancy upsampling), greyscale as 1 channel, YCbCr/RGB as RGB,
// colour space "sRGB". CMYK/YCCK files are declined (OpenImageIO converts them).
#include <cstdio>
// clang-format off: jpeglib.h needs <cstdio> first
#include <jerror.h>
#include <jpeglib.h>
// clang-format on

#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "core/codec_native.h"

namespace matfit::codec {
namespace {

struct ErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
  bool truncated = false;
};

[[noreturn]] void OnError(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<ErrorManager*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

// Warnings are not printed; a file that ends early (libjpeg pads it with an end marker and
// carries on) is an error, as OpenImageIO makes it.
void OnMessage(j_common_ptr cinfo, int level) {
  auto* e = reinterpret_cast<ErrorManager*>(cinfo->err);
  if (level < 0 && cinfo->err->msg_code == JWRN_JPEG_EOF) e->truncated = true;
}

class JpegReader : public Reader {
 public:
  // From memory (bytes, size) or from a file (file, size = its length; the reader closes it):
  // libjpeg's stdio source reads 4 KB at a time, so a header read touches only the first few.
  JpegReader(const unsigned char* bytes, FILE* file, size_t size)
      : bytes_(bytes), file_(file), size_(size) {
    cinfo_.err = jpeg_std_error(&err_.pub);
    err_.pub.error_exit = OnError;
    err_.pub.emit_message = OnMessage;
  }
  ~JpegReader() override {
    if (created_) jpeg_destroy_decompress(&cinfo_);
    if (file_) std::fclose(file_);
  }

  // false: not a JPEG this reader decodes (declined) or a broken header (error() set).
  bool OpenHeader(bool* declined) {
    *declined = false;
    if (setjmp(err_.jump)) return false;
    jpeg_create_decompress(&cinfo_);
    created_ = true;
    if (file_)
      jpeg_stdio_src(&cinfo_, file_);
    else
      jpeg_mem_src(&cinfo_, bytes_, static_cast<unsigned long>(size_));
    jpeg_read_header(&cinfo_, TRUE);
    h_.width = int(cinfo_.image_width);
    h_.height = int(cinfo_.image_height);
    // Huffman-coded data holds at least one bit per 8x8 luma block (its DC code, in baseline
    // and progressive files alike): a header declaring more blocks than 8 × the file's bytes
    // describes data the file cannot hold (truncated, or a lying header). Refused before any
    // pixel memory is allocated. (Arithmetic coding can go below a bit per block: not checked.)
    const double blocks = std::ceil(h_.width / 8.0) * std::ceil(h_.height / 8.0);
    if (!cinfo_.arith_code && blocks > 8.0 * double(size_)) {
      std::snprintf(err_.message, sizeof err_.message,
                    "the header declares %dx%d pixels (%.0f 8x8 blocks) but the file has only "
                    "%zu bytes, too few even at JPEG's best compression (1 bit per block): it is "
                    "truncated or its header is wrong",
                    h_.width, h_.height, blocks, size_);
      return false;
    }
    if (cinfo_.jpeg_color_space == JCS_GRAYSCALE) {
      cinfo_.out_color_space = JCS_GRAYSCALE;
      h_.channels = 1;
    } else if (cinfo_.jpeg_color_space == JCS_YCbCr || cinfo_.jpeg_color_space == JCS_RGB) {
      cinfo_.out_color_space = JCS_RGB;
      h_.channels = 3;
    } else {
      *declined = true;
      return false;
    }
    h_.sample = Sample::kUint8;
    h_.color_space = "sRGB";
    return true;
  }

  const Header& header() const override { return h_; }

  bool ReadRows(int y0, int y1, void* dst) override {
    auto* out = static_cast<unsigned char*>(dst);
    if (setjmp(err_.jump)) return false;
    jpeg_start_decompress(&cinfo_);
    const size_t row_bytes = size_t(h_.width) * h_.channels;
    // The rows above the band are entropy-decoded only (libjpeg-turbo skips their IDCT).
    if (y0 > 0 && jpeg_skip_scanlines(&cinfo_, JDIMENSION(y0)) != JDIMENSION(y0))
      err_.truncated = true;
    while (!err_.truncated && cinfo_.output_scanline < JDIMENSION(y1)) {
      JSAMPROW row = out + row_bytes * (cinfo_.output_scanline - JDIMENSION(y0));
      jpeg_read_scanlines(&cinfo_, &row, 1);
    }
    if (y1 == int(cinfo_.output_height) && !err_.truncated)
      jpeg_finish_decompress(&cinfo_);
    else
      jpeg_abort_decompress(&cinfo_);  // the rows below the band are not decoded
    if (err_.truncated) {
      std::strcpy(err_.message, "premature end of JPEG data (truncated file)");
      return false;
    }
    return true;
  }

  std::string error() const override {
    return err_.message[0] ? std::string(err_.message) : "unknown JPEG error";
  }

 private:
  const unsigned char* bytes_;
  FILE* file_;
  size_t size_;
  jpeg_decompress_struct cinfo_{};
  ErrorManager err_{};
  bool created_ = false;
  Header h_;
};

std::unique_ptr<Reader> Finish(std::unique_ptr<JpegReader> r, std::string* error) {
  bool declined = false;
  if (r->OpenHeader(&declined)) return r;
  if (!declined) *error = r->error();
  return nullptr;
}

}  // namespace

std::unique_ptr<Reader> OpenJpeg(const std::string& path, std::string* error) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    *error = std::string("cannot open it: ") + std::strerror(errno);
    return nullptr;
  }
  long size = -1;
  if (std::fseek(f, 0, SEEK_END) == 0) size = std::ftell(f);
  if (size < 0 || std::fseek(f, 0, SEEK_SET) != 0) {
    std::fclose(f);
    *error = std::string("cannot read it: ") + std::strerror(errno);
    return nullptr;
  }
  return Finish(std::make_unique<JpegReader>(nullptr, f, size_t(size)), error);
}

std::unique_ptr<Reader> OpenJpegMemory(const unsigned char* bytes, size_t size,
                                       std::string* error) {
  error->clear();
  if (size < 3 || bytes[0] != 0xFF || bytes[1] != 0xD8) {
    *error = "not a JPEG (no start-of-image marker)";
    return nullptr;
  }
  auto r = Finish(std::make_unique<JpegReader>(bytes, nullptr, size), error);
  if (!r && error->empty()) *error = "a CMYK/YCCK JPEG, which this reader does not decode";
  return r;
}

}  // namespace matfit::codec
