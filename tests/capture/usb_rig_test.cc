// The USB light rig against a fake firmware at the control-transfer boundary (UsbTransport):
// the protocol of capture/usb/protocol.h, plus disconnects, timeouts, stalls and wrong devices.
#include <gtest/gtest.h>

#include "capture/usb/protocol.h"
#include "capture/usb/usb_rig.h"

namespace matfit::capture {
namespace {

namespace rp = rigproto;

struct Firmware {
  uint8_t magic[4] = {'M', 'F', 'L', 'R'};
  uint8_t major = rp::kMajor, minor = 3;
  std::vector<uint16_t> level = std::vector<uint16_t>(8, 0);
  bool attached = true, hang = false, stall_set = false;
  int transfers = 0;
};

class FakeUsb final : public UsbTransport {
 public:
  explicit FakeUsb(Firmware* f) : f_(f) {}
  int Control(uint8_t type, uint8_t req, uint16_t value, uint16_t index, uint8_t* data,
              uint16_t length, unsigned) override {
    f_->transfers++;
    if (!f_->attached) return rp::kErrorNoDevice;
    if (f_->hang) return rp::kErrorTimeout;
    const bool in = type == rp::kRequestTypeIn;
    if (!in && type != rp::kRequestTypeOut) return rp::kErrorPipe;
    const size_t n = f_->level.size();
    switch (req) {
      case rp::kIdentify:
        if (!in || length < 8) return rp::kErrorPipe;
        std::copy(f_->magic, f_->magic + 4, data);
        data[4] = f_->major, data[5] = f_->minor, data[6] = uint8_t(n), data[7] = uint8_t(n >> 8);
        return 8;
      case rp::kSetLed:
        if (in || index >= n || f_->stall_set) return rp::kErrorPipe;
        f_->level[index] = value;
        return 0;
      case rp::kAllOff:
        for (auto& l : f_->level) l = 0;
        return 0;
      case rp::kSetAll:
        for (auto& l : f_->level) l = value;
        return 0;
      case rp::kGetState:
        if (!in || length < 2 * n) return rp::kErrorPipe;
        for (size_t i = 0; i < n; ++i)
          data[2 * i] = uint8_t(f_->level[i] & 0xff), data[2 * i + 1] = uint8_t(f_->level[i] >> 8);
        return int(2 * n);
    }
    return rp::kErrorPipe;
  }
  bool Connected() override { return f_->attached; }
  std::string Describe() const override { return "usb:1209:4d46:TEST"; }

 private:
  Firmware* f_;
};

std::vector<Vec3> Dirs(int n) {
  std::vector<Vec3> d;
  for (int i = 0; i < n; ++i) d.push_back({0, 0, 1});
  return d;
}

TEST(UsbRig, ProtocolRoundTrip) {
  Firmware fw;
  auto rig = OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(8));
  ASSERT_TRUE(rig.ok()) << rig.status().message();
  EXPECT_EQ((*rig)->Count(), 8);
  ASSERT_TRUE((*rig)->Set(3, 0.5).ok());
  EXPECT_EQ(fw.level[3], 32768);
  ASSERT_TRUE((*rig)->All(1).ok());
  auto st = (*rig)->State();
  ASSERT_TRUE(st.ok());
  for (double v : *st) EXPECT_DOUBLE_EQ(v, 1.0);
  ASSERT_TRUE((*rig)->AllOff().ok());
  st = (*rig)->State();
  for (double v : *st) EXPECT_DOUBLE_EQ(v, 0.0);
  EXPECT_NE((*rig)->Set(8, 1).message().find("LED 8 does not exist"), std::string::npos);
}

TEST(UsbRig, WrongDeviceVersionAndCountAreRefused) {
  Firmware fw;
  fw.magic[0] = 'X';
  EXPECT_NE(OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(8))
                .status()
                .message()
                .find("not a matfit light rig"),
            std::string::npos);
  fw.magic[0] = 'M';
  fw.major = 2;
  const auto v = OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(8)).status().message();
  EXPECT_NE(v.find("speaks protocol 2.3"), std::string::npos) << v;
  fw.major = rp::kMajor;
  const auto c = OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(6)).status().message();
  EXPECT_NE(c.find("has 8 LEDs but its calibration file gives 6"), std::string::npos) << c;
  fw.hang = true;
  EXPECT_NE(OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(8))
                .status()
                .message()
                .find("did not answer IDENTIFY"),
            std::string::npos);
}

TEST(UsbRig, DisconnectTimeoutAndStallMidSession) {
  Firmware fw;
  auto rig = OpenUsbRig(std::make_unique<FakeUsb>(&fw), Dirs(8));
  ASSERT_TRUE(rig.ok());
  fw.hang = true;
  Status st = (*rig)->Set(1, 1);
  EXPECT_EQ(st.code(), StatusCode::kUnavailable);
  EXPECT_NE(st.message().find("did not answer within 500 ms"), std::string::npos) << st.message();
  fw.hang = false;
  fw.stall_set = true;
  EXPECT_NE((*rig)->Set(1, 1).message().find("refused the request"), std::string::npos);
  fw.stall_set = false;
  fw.attached = false;  // unplugged (hotplug "left", or LIBUSB_ERROR_NO_DEVICE)
  const int before = fw.transfers;
  st = (*rig)->AllOff();
  EXPECT_NE(st.message().find("was disconnected"), std::string::npos) << st.message();
  EXPECT_EQ(fw.transfers, before) << "no transfer is attempted on a detached device";
  EXPECT_FALSE((*rig)->State().ok());
}

TEST(UsbRig, UriParsing) {
  uint16_t v, p;
  std::string s;
  ASSERT_TRUE(ParseUsbUri("usb:1209:4d46", &v, &p, &s));
  EXPECT_EQ(v, 0x1209);
  EXPECT_EQ(p, 0x4d46);
  EXPECT_EQ(s, "");
  ASSERT_TRUE(ParseUsbUri("usb:1209:4D46:RIG-7", &v, &p, &s));
  EXPECT_EQ(s, "RIG-7");
  EXPECT_FALSE(ParseUsbUri("usb:12x9:4d46", &v, &p, &s));
  EXPECT_FALSE(ParseUsbUri("usb:1209", &v, &p, &s));
  EXPECT_FALSE(ParseUsbUri("v4l2:/dev/video0", &v, &p, &s));
}

}  // namespace
}  // namespace matfit::capture
