// JPEG writing through libjpeg(-turbo): 8-bit grey or RGB at the quality the caller asks, with
// full-resolution chroma (4:4:4) — what the relight web layout's coefficient planes need, without
// loading OpenImageIO for them (core/pack/pack_exports.cc).
#include <cstdio>
// clang-format off: jpeglib.h needs <cstdio> first
#include <jpeglib.h>
// clang-format on

#include <algorithm>
#include <cerrno>
#include <csetjmp>
#include <cstring>
#include <memory>
#include <string>

#include "core/codec_file.h"
#include "core/codec_native.h"

namespace matfit::codec {
namespace {

struct WriteErrors {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

[[noreturn]] void OnWriteError(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<WriteErrors*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

// The compression itself, with nothing that needs destroying between setjmp and longjmp.
bool Compress(const WriteSpec& spec, FILE* f, WriteErrors* err) {
  jpeg_compress_struct cinfo;
  cinfo.err = jpeg_std_error(&err->pub);
  err->pub.error_exit = OnWriteError;
  if (setjmp(err->jump)) {
    jpeg_destroy_compress(&cinfo);
    return false;
  }
  jpeg_create_compress(&cinfo);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = JDIMENSION(spec.width);
  cinfo.image_height = JDIMENSION(spec.height);
  cinfo.input_components = spec.channels;
  cinfo.in_color_space = spec.channels == 3 ? JCS_RGB : JCS_GRAYSCALE;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, std::clamp(spec.jpeg_quality, 1, 100), TRUE);
  for (int c = 0; c < cinfo.num_components; ++c)  // 4:4:4
    cinfo.comp_info[c].h_samp_factor = cinfo.comp_info[c].v_samp_factor = 1;
  jpeg_start_compress(&cinfo, TRUE);
  for (int y = 0; y < spec.height; ++y) {
    const void* data = nullptr;
    try {  // the row source allocates; nothing may unwind through libjpeg
      data = spec.rows(y, y + 1);
    } catch (...) {
    }
    if (!data) {
      std::snprintf(err->message, sizeof err->message, "no memory for row %d", y);
      jpeg_destroy_compress(&cinfo);
      return false;
    }
    JSAMPROW row = static_cast<JSAMPROW>(const_cast<void*>(data));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  return true;
}

}  // namespace

bool WriteJpeg(const WriteSpec& spec, const std::string& path, std::string* error) {
  if ((spec.channels != 1 && spec.channels != 3) || spec.sample != Sample::kUint8 ||
      spec.jpeg_quality <= 0) {
    *error = "the native JPEG writer takes 1 or 3 channels of 8 bits at a given quality";
    return false;
  }
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "wb"), std::fclose);
  if (!f) {
    *error = std::string("cannot create it: ") + std::strerror(errno);
    return false;
  }
  WriteErrors err;
  if (!Compress(spec, f.get(), &err)) {
    *error = err.message[0] ? err.message : "JPEG encoder failed";
    return false;
  }
  return FlushAndClose(f.release(), error);
}

}  // namespace matfit::codec
