// The V4L2 backend against a fake device at the system-call boundary (V4l2Io). What is faked:
// open (ENOENT / EBUSY / EACCES on demand), VIDIOC_QUERYCAP, ENUM_FMT, ENUM_FRAMESIZES, G/S_FMT,
// QUERYCTRL (exposure, gain), S_CTRL, REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON/OFF, mmap into
// the fake's own buffers, and poll (ready / timeout / device gone). Frames are known patterns
// in the negotiated pixel format, so the conversion to linear float is checked exactly.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>

#include "capture/v4l2/v4l2_camera.h"
#include "core/color.h"

namespace matfit::capture {
namespace {

struct FakeState {
  int open_errno = 0;  // open fails with this
  bool gone = false;   // the device was unplugged: poll/DQBUF give ENODEV
  bool stall = false;  // no frames arrive (timeout)
  bool busy_on_s_fmt = false;
  uint32_t pixfmt = V4L2_PIX_FMT_YUYV;
  uint32_t width = 8, height = 4;
  std::vector<uint32_t> offered = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y16,
                                   V4L2_PIX_FMT_RGB24};
  std::map<uint32_t, int32_t> controls;
  int streamon = 0, streamoff = 0, frames = 0;
};

class FakeIo final : public V4l2Io {
 public:
  explicit FakeIo(FakeState* s) : s_(s) {}
  int Open(const std::string&, int) override {
    if (s_->open_errno) return errno = s_->open_errno, -1;
    return 42;
  }
  int Close(int) override { return 0; }
  void* Mmap(size_t len, int, long offset) override {
    const size_t i = size_t(offset) / 4096;
    if (i >= bufs_.size() || len > bufs_[i].size()) return MAP_FAILED;
    return bufs_[i].data();
  }
  int Munmap(void*, size_t) override { return 0; }
  int PollReadable(int, int) override {
    if (s_->gone) return errno = ENODEV, -1;
    if (s_->stall || queued_.empty() || !streaming_) return 0;
    return 1;
  }
  int Ioctl(int, unsigned long req, void* arg) override {
    switch (req) {
      case VIDIOC_QUERYCAP: {
        auto* c = static_cast<v4l2_capability*>(arg);
        std::strcpy(reinterpret_cast<char*>(c->driver), "fakecam");
        std::strcpy(reinterpret_cast<char*>(c->card), "Fake UVC Camera");
        c->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        return 0;
      }
      case VIDIOC_ENUM_FMT: {
        auto* d = static_cast<v4l2_fmtdesc*>(arg);
        if (d->index >= s_->offered.size()) return errno = EINVAL, -1;
        d->pixelformat = s_->offered[d->index];
        return 0;
      }
      case VIDIOC_ENUM_FRAMESIZES: {
        auto* f = static_cast<v4l2_frmsizeenum*>(arg);
        if (f->index > 0) return errno = EINVAL, -1;
        f->type = V4L2_FRMSIZE_TYPE_DISCRETE;
        f->discrete = {s_->width, s_->height};
        return 0;
      }
      case VIDIOC_G_FMT:
      case VIDIOC_S_FMT: {
        auto* f = static_cast<v4l2_format*>(arg);
        if (req == VIDIOC_S_FMT) {
          if (s_->busy_on_s_fmt) return errno = EBUSY, -1;
          bool ok = false;
          for (uint32_t o : s_->offered) ok = ok || o == f->fmt.pix.pixelformat;
          if (ok) s_->pixfmt = f->fmt.pix.pixelformat;  // else the driver keeps its own
        }
        f->fmt.pix.pixelformat = s_->pixfmt;
        f->fmt.pix.width = s_->width, f->fmt.pix.height = s_->height;
        f->fmt.pix.bytesperline = s_->width * Bpp() + 4;  // padded rows
        f->fmt.pix.sizeimage = f->fmt.pix.bytesperline * s_->height;
        return 0;
      }
      case VIDIOC_QUERYCTRL: {
        auto* q = static_cast<v4l2_queryctrl*>(arg);
        if (q->id == V4L2_CID_EXPOSURE_ABSOLUTE) return q->minimum = 1, q->maximum = 10000, 0;
        if (q->id == V4L2_CID_GAIN) return q->minimum = 0, q->maximum = 150, 0;
        return errno = EINVAL, -1;
      }
      case VIDIOC_S_CTRL: {
        auto* c = static_cast<v4l2_control*>(arg);
        s_->controls[c->id] = c->value;
        return 0;
      }
      case VIDIOC_REQBUFS: {
        auto* r = static_cast<v4l2_requestbuffers*>(arg);
        bufs_.assign(r->count,
                     std::vector<uint8_t>(s_->width * Bpp() * s_->height + 4 * s_->height));
        queued_.clear();
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        b->length = uint32_t(bufs_[b->index].size());
        b->m.offset = b->index * 4096;
        return 0;
      }
      case VIDIOC_QBUF: queued_.push_back(static_cast<v4l2_buffer*>(arg)->index); return 0;
      case VIDIOC_DQBUF: {
        if (s_->gone) return errno = ENODEV, -1;
        if (queued_.empty()) return errno = EAGAIN, -1;
        auto* b = static_cast<v4l2_buffer*>(arg);
        b->index = queued_.front();
        queued_.erase(queued_.begin());
        Fill(bufs_[b->index]);
        b->bytesused = uint32_t(bufs_[b->index].size());
        s_->frames++;
        return 0;
      }
      case VIDIOC_STREAMON: streaming_ = true, s_->streamon++; return 0;
      case VIDIOC_STREAMOFF: streaming_ = false, s_->streamoff++; return 0;
    }
    return errno = ENOTTY, -1;
  }

 private:
  uint32_t Bpp() const {
    return s_->pixfmt == V4L2_PIX_FMT_GREY ? 1 : s_->pixfmt == V4L2_PIX_FMT_RGB24 ? 3 : 2;
  }
  // Pixel (x, y) carries value 20 + 10 x + 40 y (8-bit) or × 257 (Y16); YUYV: Y = that, U = V =
  // 128 (grey).
  void Fill(std::vector<uint8_t>& b) const {
    const uint32_t stride = s_->width * Bpp() + 4;
    for (uint32_t y = 0; y < s_->height; ++y)
      for (uint32_t x = 0; x < s_->width; ++x) {
        const uint8_t v = uint8_t(20 + 10 * x + 40 * y);
        uint8_t* p = b.data() + y * stride + x * Bpp();
        if (s_->pixfmt == V4L2_PIX_FMT_GREY) p[0] = v;
        if (s_->pixfmt == V4L2_PIX_FMT_RGB24) p[0] = v, p[1] = uint8_t(v / 2), p[2] = 255 - v;
        if (s_->pixfmt == V4L2_PIX_FMT_Y16) p[0] = v, p[1] = v;  // v × 257
        if (s_->pixfmt == V4L2_PIX_FMT_YUYV) p[0] = v, p[1] = 128;
      }
  }
  FakeState* s_;
  std::vector<std::vector<uint8_t>> bufs_;
  std::vector<uint32_t> queued_;
  bool streaming_ = false;
};

StatusOr<std::unique_ptr<Camera>> Open(FakeState* s) {
  return OpenV4l2Camera("/dev/video9", std::make_unique<FakeIo>(s));
}

TEST(V4l2Fake, CapabilitiesFormatsAndControls) {
  FakeState s;
  auto cam = Open(&s);
  ASSERT_TRUE(cam.ok()) << cam.status().message();
  const CameraInfo i = (*cam)->Info();
  EXPECT_EQ(i.name, "Fake UVC Camera");
  EXPECT_EQ(i.formats.size(), 4u);
  EXPECT_TRUE(i.manual_exposure && i.gain);
  EXPECT_NEAR(i.exposure_max_s, 1.0, 1e-12);
  ASSERT_TRUE((*cam)->SetExposure(0.02).ok());
  EXPECT_EQ(s.controls[V4L2_CID_EXPOSURE_ABSOLUTE], 200);  // 100 µs units
  EXPECT_EQ(s.controls[V4L2_CID_EXPOSURE_AUTO], V4L2_EXPOSURE_MANUAL);
  ASSERT_TRUE((*cam)->SetGain(16).ok());
  EXPECT_EQ(s.controls[V4L2_CID_GAIN], 150);
  const Status st = (*cam)->SetExposure(5);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("range"), std::string::npos) << st.message();
}

TEST(V4l2Fake, EveryFormatConvertsToLinearFloatExactly) {
  const float* srgb = Srgb8ToLinearTable();
  for (uint32_t f : {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_RGB24, V4L2_PIX_FMT_YUYV}) {
    FakeState s;
    auto cam = Open(&s);
    ASSERT_TRUE(cam.ok());
    PixelFormat pf = f == V4L2_PIX_FMT_GREY    ? PixelFormat::kGrey
                     : f == V4L2_PIX_FMT_Y16   ? PixelFormat::kY16
                     : f == V4L2_PIX_FMT_RGB24 ? PixelFormat::kRgb24
                                               : PixelFormat::kYuyv;
    ASSERT_TRUE((*cam)->SetFormat({pf, 8, 4}).ok());
    auto img = (*cam)->Grab(100);
    ASSERT_TRUE(img.ok()) << img.status().message();
    ASSERT_EQ(img->width(), 8);
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 8; ++x) {
        const int v = 20 + 10 * x + 40 * y;
        const int64_t i = int64_t(y) * 8 + x;
        if (pf == PixelFormat::kGrey) {
          EXPECT_FLOAT_EQ(img->Plane(0)[i], srgb[v]);
        }
        if (pf == PixelFormat::kY16) {
          EXPECT_FLOAT_EQ(img->Plane(0)[i], float(v * 257) / 65535.0f);
        }
        if (pf == PixelFormat::kRgb24) {
          EXPECT_FLOAT_EQ(img->Plane(0)[i], srgb[v]);
          EXPECT_FLOAT_EQ(img->Plane(1)[i], srgb[v / 2]);
          EXPECT_FLOAT_EQ(img->Plane(2)[i], srgb[255 - v]);
        }
        if (pf == PixelFormat::kYuyv) {  // grey: r = g = b = sRGB⁻¹((Y − 16)/219)
          const float e = std::min(1.0f, std::max(0.0f, (float(v) - 16) / 219));
          for (int c = 0; c < 3; ++c) EXPECT_NEAR(img->Plane(c)[i], SrgbToLinear(e), 1e-6);
        }
      }
  }
}

TEST(V4l2Fake, ErrorsNameTheDeviceAndTheCause) {
  FakeState s;
  s.open_errno = ENOENT;
  auto r = Open(&s);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("/dev/video9: no such device"), std::string::npos);
  s.open_errno = EBUSY;
  EXPECT_NE(Open(&s).status().message().find("busy"), std::string::npos);
  s.open_errno = EACCES;
  EXPECT_NE(Open(&s).status().message().find("'video' group"), std::string::npos);
  s.open_errno = 0;
  s.offered = {V4L2_PIX_FMT_YUYV};
  auto cam = Open(&s);
  ASSERT_TRUE(cam.ok());
  Status st = (*cam)->SetFormat({PixelFormat::kY16, 8, 4});  // the driver keeps YUYV
  EXPECT_NE(st.message().find("does not deliver Y16"), std::string::npos) << st.message();
  s.busy_on_s_fmt = true;
  EXPECT_NE((*cam)->SetFormat({PixelFormat::kYuyv, 8, 4}).message().find("busy"),
            std::string::npos);
  s.busy_on_s_fmt = false;
  s.stall = true;
  auto t = (*cam)->Grab(50);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.status().message().find("no frame within 50 ms"), std::string::npos);
  s.stall = false;
  ASSERT_TRUE((*cam)->Grab(50).ok());
  s.gone = true;
  auto lost = (*cam)->Grab(50);
  ASSERT_FALSE(lost.ok());
  EXPECT_NE(lost.status().message().find("was lost"), std::string::npos) << lost.status().message();
  EXPECT_GE(s.streamoff, 1) << "streaming is stopped when the device is lost";
}

TEST(V4l2Real, AbsentDeviceGivesTheRightError) {
  auto cam = OpenV4l2Camera("/dev/video-matfit-absent", SystemV4l2Io());
  ASSERT_FALSE(cam.ok());
  EXPECT_EQ(cam.status().code(), StatusCode::kNotFound);
  EXPECT_NE(cam.status().message().find("no such device; `matfit devices` lists cameras"),
            std::string::npos);
  // /dev/video0 on this machine: absent (CI), or a real camera.
  auto v0 = OpenV4l2Camera("/dev/video0", SystemV4l2Io());
  if (!v0.ok()) {
    EXPECT_NE(v0.status().message().find("/dev/video0"), std::string::npos)
        << v0.status().message();
  }
}

}  // namespace
}  // namespace matfit::capture
