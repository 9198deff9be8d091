#include "capture/v4l2/v4l2_camera.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <vector>

#include "capture/convert.h"

namespace matfit::capture {
namespace {

struct FourCc {
  uint32_t v4l2;
  PixelFormat format;
};
constexpr FourCc kFormats[] = {{V4L2_PIX_FMT_YUYV, PixelFormat::kYuyv},
                               {V4L2_PIX_FMT_MJPEG, PixelFormat::kMjpeg},
                               {V4L2_PIX_FMT_GREY, PixelFormat::kGrey},
                               {V4L2_PIX_FMT_Y16, PixelFormat::kY16},
                               {V4L2_PIX_FMT_RGB24, PixelFormat::kRgb24}};

uint32_t ToV4l2(PixelFormat f) {
  for (const auto& k : kFormats)
    if (k.format == f) return k.v4l2;
  return 0;
}

class V4l2Camera final : public Camera {
 public:
  V4l2Camera(std::string path, std::unique_ptr<V4l2Io> io, int fd, int buffers)
      : path_(std::move(path)), io_(std::move(io)), fd_(fd), nbuf_(buffers) {}
  ~V4l2Camera() override { Close(); }

  Status Init() {
    v4l2_capability cap{};
    if (io_->Ioctl(fd_, VIDIOC_QUERYCAP, &cap) != 0)
      return Err("does not answer VIDIOC_QUERYCAP; it is not a V4L2 device");
    const uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE))
      return Err(
          "is not a video capture device (a metadata or output node?); try another "
          "/dev/videoN");
    if (!(caps & V4L2_CAP_STREAMING)) return Err("does not support mmap streaming");
    info_.uri = "v4l2:" + path_;
    info_.driver = reinterpret_cast<const char*>(cap.driver);
    info_.name = reinterpret_cast<const char*>(cap.card);
    for (uint32_t i = 0;; ++i) {
      v4l2_fmtdesc d{};
      d.index = i;
      d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      if (io_->Ioctl(fd_, VIDIOC_ENUM_FMT, &d) != 0) break;
      for (const auto& k : kFormats) {
        if (k.v4l2 != d.pixelformat) continue;
        for (uint32_t j = 0;; ++j) {
          v4l2_frmsizeenum s{};
          s.index = j;
          s.pixel_format = d.pixelformat;
          if (io_->Ioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &s) != 0) break;
          if (s.type == V4L2_FRMSIZE_TYPE_DISCRETE)
            info_.formats.push_back({k.format, int(s.discrete.width), int(s.discrete.height)});
          else  // stepwise / continuous: the largest
            info_.formats.push_back(
                {k.format, int(s.stepwise.max_width), int(s.stepwise.max_height)});
          if (s.type != V4L2_FRMSIZE_TYPE_DISCRETE) break;
        }
      }
    }
    if (info_.formats.empty())
      return Err("offers none of the formats matfit converts (YUYV, MJPEG, GREY, Y16, RGB24)");
    v4l2_queryctrl q{};
    q.id = V4L2_CID_EXPOSURE_ABSOLUTE;
    if (io_->Ioctl(fd_, VIDIOC_QUERYCTRL, &q) == 0 && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
      info_.manual_exposure = true;
      info_.exposure_min_s = q.minimum * 1e-4;  // the control counts 100 µs units
      info_.exposure_max_s = q.maximum * 1e-4;
      exposure_ctrl_ = q;
    }
    q = {};
    q.id = V4L2_CID_GAIN;
    if (io_->Ioctl(fd_, VIDIOC_QUERYCTRL, &q) == 0 && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
      info_.gain = true;
      gain_ctrl_ = q;
    }
    // Start in the device's current format if it is one we convert, else the first offered.
    v4l2_format f{};
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (io_->Ioctl(fd_, VIDIOC_G_FMT, &f) == 0) {
      for (const auto& k : kFormats)
        if (k.v4l2 == f.fmt.pix.pixelformat) {
          format_ = {k.format, int(f.fmt.pix.width), int(f.fmt.pix.height)};
          bytesperline_ = f.fmt.pix.bytesperline;
          return Status::Ok();
        }
    }
    return SetFormat(info_.formats.front());
  }

  CameraInfo Info() const override { return info_; }
  FrameFormat Format() const override { return format_; }

  Status SetFormat(const FrameFormat& want) override {
    if (fd_ < 0) return Err("is closed");
    StopStreaming();
    v4l2_format f{};
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    f.fmt.pix.width = uint32_t(want.width);
    f.fmt.pix.height = uint32_t(want.height);
    f.fmt.pix.pixelformat = ToV4l2(want.pixel_format);
    f.fmt.pix.field = V4L2_FIELD_NONE;
    if (io_->Ioctl(fd_, VIDIOC_S_FMT, &f) != 0)
      return errno == EBUSY
                 ? Err("is busy: another program is streaming from it")
                 : Err(std::string("refused format ") + PixelFormatName(want.pixel_format) + " " +
                       std::to_string(want.width) + "x" + std::to_string(want.height));
    if (f.fmt.pix.pixelformat != ToV4l2(want.pixel_format))
      return Err(std::string("does not deliver ") + PixelFormatName(want.pixel_format) +
                 "; `matfit devices` lists its formats");
    format_ = {want.pixel_format, int(f.fmt.pix.width), int(f.fmt.pix.height)};
    bytesperline_ = f.fmt.pix.bytesperline;
    return Status::Ok();
  }

  Status SetExposure(double seconds) override {
    if (!info_.manual_exposure) return Err("has no manual exposure control");
    v4l2_control c{V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL};
    io_->Ioctl(fd_, VIDIOC_S_CTRL, &c);  // not every camera has the auto control
    const long v = std::lround(seconds / 1e-4);
    if (v < exposure_ctrl_.minimum || v > exposure_ctrl_.maximum)
      return Err("cannot expose " + std::to_string(seconds) + " s; its range is " +
                 std::to_string(info_.exposure_min_s) + "–" + std::to_string(info_.exposure_max_s) +
                 " s");
    c = {V4L2_CID_EXPOSURE_ABSOLUTE, int32_t(v)};
    if (io_->Ioctl(fd_, VIDIOC_S_CTRL, &c) != 0) return Err("refused the exposure setting");
    return Status::Ok();
  }

  // Gain g ∈ [1, 16] maps linearly onto the control's range (g = 1 → minimum).
  Status SetGain(double g) override {
    if (!info_.gain) return Err("has no gain control");
    if (!(g >= 1 && g <= 16)) return InvalidArgument("gain must be in [1, 16]");
    const double t = (g - 1) / 15;
    v4l2_control c{
        V4L2_CID_GAIN,
        int32_t(std::lround(gain_ctrl_.minimum + t * (gain_ctrl_.maximum - gain_ctrl_.minimum)))};
    if (io_->Ioctl(fd_, VIDIOC_S_CTRL, &c) != 0) return Err("refused the gain setting");
    return Status::Ok();
  }

  StatusOr<Image> Grab(int timeout_ms) override {
    if (fd_ < 0) return Err("is closed");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    timespec called{};
    clock_gettime(CLOCK_MONOTONIC, &called);
    if (!streaming_) MATFIT_RETURN_IF_ERROR(StartStreaming());
    // Frames already waiting were exposed before this call (e.g. under the previous light):
    // hand them back (at most one per buffer) and wait for a fresh one.
    for (size_t k = 0; k < maps_.size() && io_->PollReadable(fd_, 0) > 0; ++k) {
      v4l2_buffer b{};
      b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b.memory = V4L2_MEMORY_MMAP;
      if (io_->Ioctl(fd_, VIDIOC_DQBUF, &b) != 0) break;
      io_->Ioctl(fd_, VIDIOC_QBUF, &b);
    }
    for (;;) {
      const int left = int(std::chrono::duration_cast<std::chrono::milliseconds>(
                               deadline - std::chrono::steady_clock::now())
                               .count());
      const int r = left <= 0 ? 0 : io_->PollReadable(fd_, left);
      if (r == 0)
        return Status(StatusCode::kUnavailable, "camera " + path_ + ": no frame within " +
                                                    std::to_string(timeout_ms) +
                                                    " ms (timeout; is the exposure longer?)");
      if (r < 0) return Lost();
      v4l2_buffer b{};
      b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b.memory = V4L2_MEMORY_MMAP;
      if (io_->Ioctl(fd_, VIDIOC_DQBUF, &b) != 0) {
        if (errno == EAGAIN) continue;
        return Lost();
      }
      if (b.index >= maps_.size()) return Err("returned an unknown buffer index");
      // A frame whose exposure started before this call (monotonic driver timestamp) saw the
      // previous light or exposure: skip it.
      const bool stale =
          (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
          (b.timestamp.tv_sec != 0 || b.timestamp.tv_usec != 0) &&
          (b.timestamp.tv_sec < called.tv_sec ||
           (b.timestamp.tv_sec == called.tv_sec && b.timestamp.tv_usec * 1000L < called.tv_nsec));
      const bool corrupt = stale || (b.flags & V4L2_BUF_FLAG_ERROR) != 0;
      StatusOr<Image> img = corrupt
                                ? StatusOr<Image>(DataError("corrupt frame"))
                                : ConvertFrame(static_cast<const uint8_t*>(maps_[b.index].first),
                                               b.bytesused, format_, bytesperline_);
      if (io_->Ioctl(fd_, VIDIOC_QBUF, &b) != 0) return Lost();
      if (corrupt) continue;  // flagged by the driver, or stale: take the next one (same deadline)
      if (!img.ok()) return Err("sent a frame that cannot be decoded: " + img.status().message());
      return img;
    }
  }

  void Close() override {
    if (fd_ < 0) return;
    StopStreaming();
    io_->Close(fd_);
    fd_ = -1;
  }

 private:
  Status Err(const std::string& what) const {
    return Status(StatusCode::kUnavailable, "camera " + path_ + " " + what);
  }
  Status Lost() {
    const int e = errno;  // before the clean-up ioctls overwrite it
    StopStreaming();
    if (e != ENODEV && e != ENXIO && e != EIO)
      return Status(StatusCode::kUnavailable,
                    "camera " + path_ + ": streaming failed (" + std::strerror(e) + ")");
    return Status(StatusCode::kUnavailable,
                  "camera " + path_ + " was lost (unplugged or reset: " + std::strerror(e) +
                      "); reconnect it and resume the capture");
  }

  Status StartStreaming() {
    Status st = TryStartStreaming();
    if (!st.ok()) {
      StopStreaming();
      FreeBuffers();  // REQBUFS 0 even when nothing was mapped
    }
    return st;
  }

  void FreeBuffers() {
    v4l2_requestbuffers req{};
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    io_->Ioctl(fd_, VIDIOC_REQBUFS, &req);
  }

  Status TryStartStreaming() {
    v4l2_requestbuffers req{};
    req.count = uint32_t(nbuf_);
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (io_->Ioctl(fd_, VIDIOC_REQBUFS, &req) != 0)
      return errno == EBUSY ? Err("is busy: another program is streaming from it")
                            : Err("cannot allocate streaming buffers");
    if (req.count < 2) return Err("granted fewer than 2 streaming buffers");
    for (uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer b{};
      b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b.memory = V4L2_MEMORY_MMAP;
      b.index = i;
      if (io_->Ioctl(fd_, VIDIOC_QUERYBUF, &b) != 0) return Err("cannot query buffer");
      void* p = io_->Mmap(b.length, fd_, long(b.m.offset));
      if (p == MAP_FAILED) return Err("cannot map buffer");
      maps_.push_back({p, b.length});
      if (io_->Ioctl(fd_, VIDIOC_QBUF, &b) != 0) return Err("cannot queue buffer");
    }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (io_->Ioctl(fd_, VIDIOC_STREAMON, &type) != 0)
      return errno == EBUSY ? Err("is busy: another program is streaming from it")
                            : Err("cannot start streaming");
    streaming_ = true;
    return Status::Ok();
  }

  void StopStreaming() {
    if (streaming_) {
      int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      io_->Ioctl(fd_, VIDIOC_STREAMOFF, &type);
      streaming_ = false;
    }
    for (auto& [p, len] : maps_) io_->Munmap(p, len);
    if (!maps_.empty()) {
      v4l2_requestbuffers req{};
      req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      req.memory = V4L2_MEMORY_MMAP;
      io_->Ioctl(fd_, VIDIOC_REQBUFS, &req);  // count 0 frees them
    }
    maps_.clear();
  }

  std::string path_;
  std::unique_ptr<V4l2Io> io_;
  int fd_;
  int nbuf_;
  CameraInfo info_;
  FrameFormat format_;
  size_t bytesperline_ = 0;
  v4l2_queryctrl exposure_ctrl_{}, gain_ctrl_{};
  bool streaming_ = false;
  std::vector<std::pair<void*, size_t>> maps_;
};

}  // namespace

StatusOr<std::unique_ptr<Camera>> OpenV4l2Camera(const std::string& path,
                                                 std::unique_ptr<V4l2Io> io, int buffers) {
  const int fd = io->Open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    if (e == ENOENT || e == ENODEV || e == ENXIO)
      return NotFound("camera " + path + ": no such device; `matfit devices` lists cameras");
    if (e == EBUSY)
      return Status(StatusCode::kUnavailable,
                    "camera " + path + " is busy: another program has it open");
    if (e == EACCES || e == EPERM)
      return Status(StatusCode::kUnavailable,
                    "camera " + path + ": permission denied; add your user to the 'video' group");
    return Status(StatusCode::kUnavailable, "camera " + path + ": " + std::strerror(e));
  }
  auto cam = std::make_unique<V4l2Camera>(path, std::move(io), fd, buffers);
  MATFIT_RETURN_IF_ERROR(cam->Init());
  return std::unique_ptr<Camera>(std::move(cam));
}

std::vector<std::string> ListV4l2Cameras(V4l2Io& io) {
  std::vector<std::string> out;
  std::error_code ec;
  std::vector<std::string> nodes;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec))
    if (e.path().filename().string().rfind("video", 0) == 0) nodes.push_back(e.path().string());
  std::sort(nodes.begin(), nodes.end());
  for (const auto& n : nodes) {
    const int fd = io.Open(n, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) continue;
    v4l2_capability cap{};
    if (io.Ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0) {
      const uint32_t caps =
          (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
      if (caps & V4L2_CAP_VIDEO_CAPTURE)
        out.push_back("v4l2:" + n + " (" + reinterpret_cast<const char*>(cap.card) + ")");
    }
    io.Close(fd);
  }
  return out;
}

}  // namespace matfit::capture
