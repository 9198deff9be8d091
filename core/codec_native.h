// The native codecs' entry points (core/codec_*.cc), combined by Native() in codec_native.cc.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/image_codec.h"

namespace matfit::codec {

// Readers: nullptr with *error empty when the file is declined (OpenImageIO reads it instead).
std::unique_ptr<Reader> OpenJpeg(const std::string& path, std::string* error);
std::unique_ptr<Reader> OpenPng(const std::string& path, std::string* error);
std::unique_ptr<Reader> OpenExr(const std::string& path, std::string* error);

// Writers: to `path`, or into *memory when not null (PNG only).
bool WritePng(const WriteSpec& spec, const std::string& path, std::string* memory,
              std::string* error);
bool WriteExr(const WriteSpec& spec, const std::string& path, std::string* error);
// 8-bit grey or RGB at spec.jpeg_quality (> 0), 4:4:4 (core/codec_jpeg_write.cc).
bool WriteJpeg(const WriteSpec& spec, const std::string& path, std::string* error);

}  // namespace matfit::codec
