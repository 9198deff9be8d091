// Closing a file an encoder wrote (shared by the native codecs and the OpenImageIO module).
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

namespace matfit::codec {

// Flushes and closes `f` (always closed): false with errno's reason in *error — buffered bytes
// meet a full disk here.
inline bool FlushAndClose(std::FILE* f, std::string* error) {
  errno = 0;
  const bool flushed = std::fflush(f) == 0;
  const int flush_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (flushed && closed) return true;
  const int e = !flushed && flush_errno != 0 ? flush_errno : errno;
  *error = std::strerror(e != 0 ? e : EIO);
  return false;
}

}  // namespace matfit::codec
