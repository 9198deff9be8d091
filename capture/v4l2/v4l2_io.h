// The system-call boundary of the V4L2 backend: everything the camera does to the kernel goes
// through this interface, so that tests can put a fake device behind it (tests/capture).
#pragma once

#include <cstddef>
#include <memory>
#include <string>

namespace matfit::capture {

class V4l2Io {
 public:
  virtual ~V4l2Io() = default;
  // Same contracts as the system calls: -1 and errno on failure.
  virtual int Open(const std::string& path, int flags) = 0;
  virtual int Close(int fd) = 0;
  virtual int Ioctl(int fd, unsigned long request, void* arg) = 0;
  virtual void* Mmap(size_t length, int fd, long offset) = 0;  // MAP_FAILED on failure
  virtual int Munmap(void* addr, size_t length) = 0;
  // Waits until a frame can be dequeued: 1 ready, 0 timeout, -1 error (errno; ENODEV = gone).
  virtual int PollReadable(int fd, int timeout_ms) = 0;
};

// The real kernel interface (open/ioctl/mmap/poll).
std::unique_ptr<V4l2Io> SystemV4l2Io();

}  // namespace matfit::capture
