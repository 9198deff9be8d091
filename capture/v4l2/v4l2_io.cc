#include "capture/v4l2/v4l2_io.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

namespace matfit::capture {
namespace {

class SystemIo final : public V4l2Io {
 public:
  int Open(const std::string& path, int flags) override { return ::open(path.c_str(), flags); }
  int Close(int fd) override { return ::close(fd); }
  int Ioctl(int fd, unsigned long request, void* arg) override {
    int r;
    do r = ::ioctl(fd, request, arg);
    while (r == -1 && errno == EINTR);
    return r;
  }
  void* Mmap(size_t length, int fd, long offset) override {
    return ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
  }
  int Munmap(void* addr, size_t length) override { return ::munmap(addr, length); }
  int PollReadable(int fd, int timeout_ms) override {
    pollfd p{fd, POLLIN, 0};
    int r;
    do r = ::poll(&p, 1, timeout_ms);
    while (r == -1 && errno == EINTR);
    if (r > 0 && (p.revents & (POLLERR | POLLHUP | POLLNVAL))) return errno = ENODEV, -1;
    return r;
  }
};

}  // namespace

std::unique_ptr<V4l2Io> SystemV4l2Io() { return std::make_unique<SystemIo>(); }

}  // namespace matfit::capture
