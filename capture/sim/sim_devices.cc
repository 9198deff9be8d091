#include "capture/sim/sim_devices.h"

#include <cmath>
#include <cstdlib>
#include <random>
#include <set>

#include "capture/convert.h"
#include "core/model/model.h"
#include "core/synth/light_sets.h"
#include "core/synth/materials.h"
#include "core/synth/render_stack.h"

namespace matfit::capture {
namespace {

class SimRig final : public LightRig {
 public:
  SimRig(std::string spec, std::vector<LightSample> lights)
      : spec_(std::move(spec)), lights_(std::move(lights)), level_(lights_.size(), 0.0) {}
  std::string Describe() const override { return "sim:rig?lights=" + spec_; }
  int Count() const override { return int(lights_.size()); }
  Vec3 Direction(int led) const override { return lights_[size_t(led)].direction; }
  Status Set(int led, double level) override {
    if (led < 0 || led >= Count())
      return InvalidArgument("LED " + std::to_string(led) + " does not exist; the rig has " +
                             std::to_string(Count()));
    level_[size_t(led)] = std::min(1.0, std::max(0.0, level));
    return Status::Ok();
  }
  Status AllOff() override { return All(0); }
  Status All(double level) override {
    for (auto& l : level_) l = std::min(1.0, std::max(0.0, level));
    return Status::Ok();
  }
  StatusOr<std::vector<double>> State() override { return level_; }
  const std::vector<double>& levels() const { return level_; }

 private:
  std::string spec_;
  std::vector<LightSample> lights_;
  std::vector<double> level_;
};

double Num(const std::map<std::string, std::string>& q, const char* k, double def) {
  const auto it = q.find(k);
  return it == q.end() ? def : std::strtod(it->second.c_str(), nullptr);
}

class SimCamera final : public Camera {
 public:
  SimCamera(std::string uri, MaterialMaps m, std::map<std::string, std::string> q)
      : maps_(std::move(m)) {
    // The identity of the camera: every parameter except the test hook fail_after, so that a
    // capture interrupted by a simulated disconnect resumes with the same camera.
    std::string base;
    ParseUriQuery(uri, &base);
    uri_ = base;
    char sep = '?';
    for (const auto& [k, v] : q)
      if (k != "fail_after") uri_ += sep + k + "=" + v, sep = '&';
    seed_ = uint64_t(int64_t(Num(q, "seed", 1)));
    full_well_ = Num(q, "full_well", 20000);
    read_noise_ = Num(q, "read_noise", 0.0005);
    black_ = Num(q, "black", 0.004);
    vignette_ = Num(q, "vignette", 0.15);
    sensitivity_ = Num(q, "sensitivity", 10);
    fail_after_ = int(Num(q, "fail_after", -1));
    format_ = {PixelFormat::kY16, maps_.width, maps_.height};
    if (q.count("format")) ParsePixelFormat(q.at("format"), &format_.pixel_format);
  }

  CameraInfo Info() const override {
    CameraInfo i;
    i.uri = uri_;
    i.driver = "sim";
    i.name = "simulated camera (" + std::to_string(maps_.width) + "x" +
             std::to_string(maps_.height) + ")";
    for (auto f : {PixelFormat::kY16, PixelFormat::kGrey, PixelFormat::kRgb24})
      i.formats.push_back({f, maps_.width, maps_.height});
    i.manual_exposure = i.gain = true;
    i.exposure_min_s = 1e-4, i.exposure_max_s = 10;
    return i;
  }
  Status SetFormat(const FrameFormat& f) override {
    if (f.pixel_format != PixelFormat::kY16 && f.pixel_format != PixelFormat::kGrey &&
        f.pixel_format != PixelFormat::kRgb24)
      return Status(StatusCode::kUnavailable,
                    "camera " + uri_ + " does not deliver " + PixelFormatName(f.pixel_format));
    format_ = {f.pixel_format, maps_.width, maps_.height};  // the sensor size is fixed
    return Status::Ok();
  }
  FrameFormat Format() const override { return format_; }
  Status SetExposure(double s) override {
    if (!(s >= 1e-4 && s <= 10))
      return Status(StatusCode::kUnavailable, "camera " + uri_ + " cannot expose " +
                                                  std::to_string(s) +
                                                  " s; its range is 0.0001–10 s");
    exposure_ = s;
    return Status::Ok();
  }
  Status SetGain(double g) override {
    if (!(g >= 1 && g <= 16)) return InvalidArgument("gain must be in [1, 16]");
    gain_ = g;
    return Status::Ok();
  }
  void AttachLightRig(LightRig* rig) override { rig_ = dynamic_cast<SimRig*>(rig); }
  void Close() override {}

  StatusOr<Image> Grab(int) override {
    if (fail_after_ >= 0 && grabs_ >= fail_after_)
      return Status(StatusCode::kUnavailable,
                    "camera " + uri_ + " was lost (simulated disconnect after " +
                        std::to_string(fail_after_) + " frames); reconnect it and resume");
    ++grabs_;
    const int w = maps_.width, h = maps_.height;
    const int64_t n = int64_t(w) * h;
    // Scene radiance: the lit LEDs' contributions, shaded by the shared CPU functions.
    std::vector<LightSample> lit;
    std::string key;
    if (rig_)
      for (int i = 0; i < rig_->Count(); ++i)
        if (rig_->levels()[size_t(i)] > 0) {
          LightSample s;
          s.direction = rig_->Direction(i);
          const double l = rig_->levels()[size_t(i)];
          s.intensity = {l, l, l};
          lit.push_back(s);
          key += std::to_string(i) + ":" + std::to_string(l) + ",";
        }
    Image radiance(w, h, 3);
    if (!lit.empty()) {
      synth::RenderOptions ro;
      const LightStack st = synth::RenderStack(maps_, lit, ro);
      for (int k = 0; k < st.num_images(); ++k)
        for (int c = 0; c < 3; ++c) {
          const auto src = st.Plane(k, std::min(c, st.channels() - 1));
          for (int64_t i = 0; i < n; ++i) radiance.Plane(c)[i] += src[i];
        }
    }
    // The noise depends on what is being captured and how often it was captured the same way,
    // so that a resumed capture reproduces an uninterrupted one bit for bit.
    key += "e" + std::to_string(exposure_) + "g" + std::to_string(gain_);
    const int repeat = key == last_key_ ? ++same_ : (same_ = 0);
    last_key_ = key;
    std::mt19937_64 rng(seed_ ^ std::hash<std::string>()(key) ^
                        (uint64_t(repeat) * 0x9E3779B97F4A7C15ull));
    std::normal_distribution<double> gauss(0, 1);
    const bool grey = format_.pixel_format != PixelFormat::kRgb24;
    const int bpp = BytesPerPixel(format_.pixel_format);
    std::vector<uint8_t> frame(size_t(n) * bpp);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int64_t i = int64_t(y) * w + x;
        const double v = Vignette(x, y);
        for (int c = 0; c < (grey ? 1 : 3); ++c) {
          const double rad =
              grey ? (radiance.Plane(0)[i] + radiance.Plane(1)[i] + radiance.Plane(2)[i]) / 3
                   : radiance.Plane(c)[i];
          const double signal = rad * v * exposure_ * sensitivity_ * gain_;  // full-scale units
          const double electrons = std::max(0.0, signal) * full_well_ / gain_;
          double value = black_ + signal + gauss(rng) * std::sqrt(electrons) * gain_ / full_well_ +
                         gauss(rng) * read_noise_ * gain_;
          value = std::min(1.0, std::max(0.0, value));  // saturation at full scale
          if (format_.pixel_format == PixelFormat::kY16) {
            const uint16_t q = uint16_t(std::lround(value * 65535));
            frame[size_t(2 * i)] = uint8_t(q & 0xff), frame[size_t(2 * i + 1)] = uint8_t(q >> 8);
          } else {  // 8-bit formats carry sRGB-encoded values, as UVC cameras do
            const double e =
                value <= 0.0031308 ? 12.92 * value : 1.055 * std::pow(value, 1 / 2.4) - 0.055;
            frame[size_t(i) * bpp + size_t(c)] = uint8_t(std::lround(e * 255));
          }
        }
      }
    return ConvertFrame(frame.data(), frame.size(), format_);
  }

  double Vignette(int x, int y) const {  // 1 − k r², r = 1 at the frame corners
    const double cx = (maps_.width - 1) / 2.0, cy = (maps_.height - 1) / 2.0;
    const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (cx * cx + cy * cy + 1e-12);
    return 1 - vignette_ * r2;
  }
  const MaterialMaps& maps() const { return maps_; }
  double sensitivity() const { return sensitivity_; }

 private:
  std::string uri_;
  MaterialMaps maps_;
  uint64_t seed_;
  double full_well_, read_noise_, black_, vignette_, sensitivity_;
  int fail_after_, grabs_ = 0;
  FrameFormat format_;
  double exposure_ = 0.01, gain_ = 1;
  SimRig* rig_ = nullptr;
  std::string last_key_;
  int same_ = 0;
};

}  // namespace

std::map<std::string, std::string> ParseUriQuery(const std::string& uri, std::string* base) {
  std::map<std::string, std::string> q;
  const auto at = uri.find('?');
  *base = uri.substr(0, at);
  if (at == std::string::npos) return q;
  std::string rest = uri.substr(at + 1);
  size_t start = 0;
  while (start <= rest.size()) {
    size_t end = rest.find('&', start);
    if (end == std::string::npos) end = rest.size();
    const std::string kv = rest.substr(start, end - start);
    const auto eq = kv.find('=');
    if (!kv.empty()) q[kv.substr(0, eq)] = eq == std::string::npos ? "" : kv.substr(eq + 1);
    start = end + 1;
  }
  return q;
}

StatusOr<std::unique_ptr<LightRig>> OpenSimRig(const std::string& uri) {
  std::string base;
  auto q = ParseUriQuery(uri, &base);
  const std::string spec = q.count("lights") ? q["lights"] : "bonn81";
  auto lights = synth::MakeLightSet(spec, 1);
  if (!lights.ok()) return InvalidArgument("light rig " + uri + ": " + lights.status().message());
  return std::unique_ptr<LightRig>(new SimRig(spec, std::move(*lights)));
}

StatusOr<std::unique_ptr<Camera>> OpenSimCamera(const std::string& uri) {
  std::string base;
  auto q = ParseUriQuery(uri, &base);
  static const std::set<std::string> kKeys = {"material",    "size",       "seed",  "format",
                                              "full_well",   "read_noise", "black", "vignette",
                                              "sensitivity", "fail_after"};
  for (const auto& [k, v] : q)
    if (!kKeys.count(k))
      return InvalidArgument("camera " + uri + ": unknown parameter '" + k + "'");
  const std::string material = q.count("material") ? q["material"] : "plaster";
  const int size = int(Num(q, "size", 64));
  if (size < 8 || size > 4096)
    return InvalidArgument("camera " + uri + ": size must be in [8, 4096]");
  if (q.count("format")) {
    PixelFormat f;
    if (!ParsePixelFormat(q["format"], &f) ||
        (f != PixelFormat::kY16 && f != PixelFormat::kGrey && f != PixelFormat::kRgb24))
      return InvalidArgument("camera " + uri + ": format must be Y16, GREY or RGB24");
  }
  StatusOr<MaterialMaps> m = InvalidArgument("");
  if (material == "flat") {  // a uniform white diffuser: the flat-field target
    MaterialMaps f;
    f.model = ModelId("lambert");
    f.width = f.height = size;
    f.albedo = Image(size, size, 3);
    for (auto& v : f.albedo.data()) v = 0.9f;
    f.normal = Image(size, size, 3);
    for (int64_t i = 0; i < int64_t(size) * size; ++i) f.normal.Plane(2)[i] = 1;
    f.mask = Image(size, size, 1);
    for (auto& v : f.mask.data()) v = 1;
    m = std::move(f);
  } else {
    m = synth::MakeMaterial(material, size, uint64_t(int64_t(Num(q, "seed", 1))));
  }
  if (!m.ok()) return InvalidArgument("camera " + uri + ": " + m.status().message());
  return std::unique_ptr<Camera>(new SimCamera(uri, std::move(*m), q));
}

const MaterialMaps* SimCameraTruth(const Camera& camera, bool flat_fielded, MaterialMaps* out) {
  const auto* sim = dynamic_cast<const SimCamera*>(&camera);
  if (!sim) return nullptr;
  *out = sim->maps();
  const int w = out->width, h = out->height;
  double mean_v = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) mean_v += sim->Vignette(x, y);
  mean_v /= double(w) * h;
  const bool grey = sim->Format().pixel_format != PixelFormat::kRgb24;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int64_t i = int64_t(y) * w + x;
      if (grey) {  // a grey sensor sees the mean of the channels (as Grab renders it)
        float m = 0;
        for (int c = 0; c < 3; ++c) m += out->albedo.Plane(c)[i] / 3;
        for (int c = 0; c < 3; ++c) out->albedo.Plane(c)[i] = m;
      }
      const double k = sim->sensitivity() * (flat_fielded ? mean_v : sim->Vignette(x, y));
      for (int c = 0; c < out->albedo.channels(); ++c)
        out->albedo.Plane(c)[int64_t(y) * w + x] *= float(k);
    }
  return out;
}

}  // namespace matfit::capture
