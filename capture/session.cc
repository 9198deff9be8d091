#include "capture/session.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "capture/sim/sim_devices.h"
#include "core/atomic_file.h"
#include "core/image_io.h"

namespace matfit::capture {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string Name(int k) {
  char b[32];
  std::snprintf(b, sizeof b, "img_%03d.exr", k);
  return b;
}

json PlanJson(const CapturePlan& p) {
  json j = {{"leds", p.leds},
            {"exposures_s", p.exposures_s},
            {"gain", p.gain},
            {"repeats", p.repeats},
            {"dark_frames", p.dark_frames},
            {"level", p.level},
            {"flat_field", p.flat_field},
            {"timeout_ms", p.timeout_ms}};
  if (p.has_format)
    j["format"] = {{"pixel_format", PixelFormatName(p.format.pixel_format)},
                   {"width", p.format.width},
                   {"height", p.format.height}};
  return j;
}

// The mean of `repeats` frames at the current settings.
StatusOr<Image> Average(Camera& cam, int repeats, int timeout_ms) {
  Image sum;
  for (int r = 0; r < repeats; ++r) {
    auto f = cam.Grab(timeout_ms);
    if (!f.ok()) return f.status();
    if (r == 0) {
      sum = std::move(*f);
      continue;
    }
    for (size_t i = 0; i < sum.data().size(); ++i) sum.data()[i] += f->data()[i];
  }
  for (float& v : sum.data()) v /= float(repeats);
  return sum;
}

// Dark frames at every exposure of the bracket (all LEDs off).
StatusOr<std::vector<Image>> Darks(Camera& cam, LightRig& rig, const CapturePlan& p) {
  std::vector<Image> darks;
  if (p.dark_frames == 0) return darks;
  MATFIT_RETURN_IF_ERROR(rig.AllOff());
  for (double t : p.exposures_s) {
    MATFIT_RETURN_IF_ERROR(cam.SetExposure(t));
    auto d = Average(cam, p.dark_frames, p.timeout_ms);
    if (!d.ok()) return d.status();
    darks.push_back(std::move(*d));
  }
  return darks;
}

// The HDR radiance of whatever the rig lights now.
StatusOr<Image> Bracketed(Camera& cam, const CapturePlan& p, const std::vector<Image>& darks,
                          int64_t* saturated) {
  std::vector<Image> frames;
  for (double t : p.exposures_s) {
    MATFIT_RETURN_IF_ERROR(cam.SetExposure(t));
    auto f = Average(cam, p.repeats, p.timeout_ms);
    if (!f.ok()) return f.status();
    frames.push_back(std::move(*f));
  }
  std::vector<Bracket> b;
  for (size_t i = 0; i < frames.size(); ++i)
    b.push_back({&frames[i], darks.empty() ? nullptr : &darks[i], p.exposures_s[i]});
  return MergeBrackets(b, p.hdr, saturated);
}

Status Setup(Camera& cam, LightRig& rig, const CapturePlan& p) {
  cam.AttachLightRig(&rig);
  if (p.has_format) MATFIT_RETURN_IF_ERROR(cam.SetFormat(p.format));
  MATFIT_RETURN_IF_ERROR(cam.SetGain(p.gain));
  for (int led : p.leds)
    if (led < 0 || led >= rig.Count())
      return InvalidArgument("plan '" + p.source + "': LED " + std::to_string(led) +
                             " does not exist; the rig has " + std::to_string(rig.Count()));
  return Status::Ok();
}

ImageWriteOptions Exr() {
  ImageWriteOptions o;
  o.format = ::matfit::PixelFormat::kFloat;
  o.transfer = TransferFunction::kLinear;
  return o;
}

}  // namespace

bool CapturePlan::Check(std::string* why) const {
  auto fail = [&](const std::string& m) { return *why = "plan '" + source + "': " + m, false; };
  if (exposures_s.empty()) return fail("'exposures_s' needs at least one exposure");
  for (double t : exposures_s)
    if (!(t > 0 && t <= 3600)) return fail("every exposure must be in (0, 3600] s");
  if (!(gain >= 1 && gain <= 16)) return fail("'gain' must be in [1, 16]");
  if (repeats < 1 || repeats > 1000) return fail("'repeats' must be in [1, 1000]");
  if (dark_frames < 0 || dark_frames > 1000) return fail("'dark_frames' must be in [0, 1000]");
  if (!(level > 0 && level <= 1)) return fail("'level' must be in (0, 1]");
  if (timeout_ms < 1) return fail("'timeout_ms' must be ≥ 1");
  if (!(hdr.low >= 0 && hdr.low < hdr.high && hdr.high <= 1))
    return fail("'hdr_range' must be 0 ≤ low < high ≤ 1");
  return true;
}

StatusOr<CapturePlan> ReadPlan(const std::string& path) {
  std::ifstream in(path);
  if (!in) return NotFound("cannot open capture plan '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  json j;
  try {
    j = json::parse(text.str());
  } catch (const json::parse_error& e) {
    return DataError("capture plan '" + path + "' is not valid JSON: " + e.what());
  }
  CapturePlan p;
  p.source = path;
  auto bad = [&](const std::string& f, const std::string& why) {
    return DataError("capture plan '" + path + "': field '" + f + "' " + why);
  };
  if (!j.is_object()) return DataError("capture plan '" + path + "' must be a JSON object");
  static const std::set<std::string> kFields = {
      "schema", "leds",       "exposures_s", "gain",       "repeats",  "dark_frames",
      "level",  "flat_field", "format",      "timeout_ms", "hdr_range"};
  for (const auto& [k, v] : j.items())
    if (!kFields.count(k)) return bad(k, "is not a plan field (see docs/capture.md)");
  if (j.contains("leds")) {
    if (j["leds"].is_string() && j["leds"] == "all") {
    } else if (j["leds"].is_array()) {
      for (const auto& v : j["leds"]) {
        if (!v.is_number_integer()) return bad("leds", "must list LED indices (integers)");
        p.leds.push_back(v.get<int>());
      }
    } else {
      return bad("leds", "must be \"all\" or a list of LED indices");
    }
  }
  if (!j.contains("exposures_s") || !j["exposures_s"].is_array())
    return bad("exposures_s", "is required: a list of exposures in seconds");
  for (const auto& v : j["exposures_s"]) {
    if (!v.is_number()) return bad("exposures_s", "must list numbers (seconds)");
    p.exposures_s.push_back(v.get<double>());
  }
  auto number = [&](const char* f, double* out) -> Status {
    if (!j.contains(f)) return Status::Ok();
    if (!j[f].is_number()) return bad(f, "must be a number");
    *out = j[f].get<double>();
    return Status::Ok();
  };
  double repeats = p.repeats, darks = p.dark_frames, timeout = p.timeout_ms;
  MATFIT_RETURN_IF_ERROR(number("gain", &p.gain));
  MATFIT_RETURN_IF_ERROR(number("repeats", &repeats));
  MATFIT_RETURN_IF_ERROR(number("dark_frames", &darks));
  MATFIT_RETURN_IF_ERROR(number("level", &p.level));
  MATFIT_RETURN_IF_ERROR(number("timeout_ms", &timeout));
  p.repeats = int(repeats), p.dark_frames = int(darks), p.timeout_ms = int(timeout);
  if (j.contains("hdr_range")) {
    const json& r = j["hdr_range"];
    if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number())
      return bad("hdr_range", "must be [low, high] in full-scale units");
    p.hdr.low = r[0].get<double>(), p.hdr.high = r[1].get<double>();
  }
  if (j.contains("flat_field")) {
    if (!j["flat_field"].is_string()) return bad("flat_field", "must be a file name");
    fs::path f = j["flat_field"].get<std::string>();
    if (f.is_relative()) f = fs::path(path).parent_path() / f;
    p.flat_field = f.string();
  }
  if (j.contains("format")) {
    const json& f = j["format"];
    if (!f.is_object() || !f.contains("pixel_format") || !f["pixel_format"].is_string() ||
        !ParsePixelFormat(f["pixel_format"].get<std::string>(), &p.format.pixel_format))
      return bad("format", "needs pixel_format YUYV, MJPEG, GREY, Y16 or RGB24");
    if (!f.value("width", json(0)).is_number_integer() ||
        !f.value("height", json(0)).is_number_integer())
      return bad("format", "needs integer width and height");
    p.format.width = f.value("width", 0), p.format.height = f.value("height", 0);
    if (p.format.width <= 0 || p.format.height <= 0)
      return bad("format", "needs positive width and height");
    p.has_format = true;
  }
  std::string why;
  if (!p.Check(&why)) return DataError(why);
  return p;
}

StatusOr<CaptureResult> RunCapture(Camera& cam, LightRig& rig, const CapturePlan& plan,
                                   const std::string& out, bool overwrite,
                                   const CaptureProgress& progress) {
  std::string why;
  if (!plan.Check(&why)) return InvalidArgument(why);
  MATFIT_RETURN_IF_ERROR(Setup(cam, rig, plan));
  std::vector<int> leds = plan.leds;
  if (leds.empty())
    for (int i = 0; i < rig.Count(); ++i) leds.push_back(i);
  const json plan_json = PlanJson(plan);
  const std::string camera_uri = cam.Info().uri, rig_name = rig.Describe();
  std::error_code ec;
  const fs::path dir(out), record_path = dir / "capture.json";

  // Resume: same plan and devices, images already written are kept.
  json record;
  if (fs::exists(record_path, ec) && !overwrite) {
    std::ifstream in(record_path);
    record = json::parse(in, nullptr, false);
    if (!record.is_object() || record.value("plan", json()) != plan_json ||
        record.value("camera", "") != camera_uri || record.value("rig", "") != rig_name)
      return InvalidArgument("'" + out +
                             "' holds a capture with another plan or other devices; choose "
                             "another --out or pass --force to start again");
    if (record.value("complete", false))
      return InvalidArgument("'" + out + "' holds a finished capture; pass --force to redo it");
  } else {
    if (fs::exists(dir, ec) && !overwrite && !fs::is_empty(dir, ec))
      return InvalidArgument("'" + out +
                             "' exists and is not a capture; choose another --out "
                             "or pass --force");
    if (overwrite && fs::exists(dir, ec) && !fs::is_empty(dir, ec)) {
      // --force replaces a capture, never an arbitrary folder.
      if (!fs::exists(record_path, ec))
        return InvalidArgument("'" + out +
                               "' is not a capture (no capture.json); --force only replaces "
                               "captures — choose another --out");
      fs::remove_all(dir, ec);
    }
    fs::create_directories(dir, ec);
    if (ec) return IoError("cannot create '" + out + "': " + ec.message());
    record = {{"schema", "matfit.capture/1"},
              {"plan", plan_json},
              {"camera", camera_uri},
              {"rig", rig_name},
              {"complete", false},
              {"images", json::array()}};
  }
  const CameraInfo info = cam.Info();
  record["camera_info"] = {{"driver", info.driver},
                           {"name", info.name},
                           {"format",
                            {{"pixel_format", PixelFormatName(cam.Format().pixel_format)},
                             {"width", cam.Format().width},
                             {"height", cam.Format().height}}}};
  auto save = [&] {
    return WriteFileAtomic(record_path.string(),
                           record.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
  };
  std::map<int, bool> done;
  for (const auto& im : record["images"])
    if (fs::exists(dir / im.value("file", ""), ec)) done[im.value("index", -1)] = true;

  Image flat;
  if (!plan.flat_field.empty()) {
    ImageReadOptions ro;
    ro.color_space = ColorSpaceChoice::kLinear;
    auto f = ReadImage(plan.flat_field, ro);
    if (!f.ok()) return f.status();
    if (f->width() != cam.Format().width || f->height() != cam.Format().height)
      return InvalidArgument("flat field '" + plan.flat_field + "' is " +
                             std::to_string(f->width()) + "x" + std::to_string(f->height()) +
                             " but the camera delivers " + std::to_string(cam.Format().width) +
                             "x" + std::to_string(cam.Format().height));
    flat = NormaliseFlat(*f);
  }
  auto darks = Darks(cam, rig, plan);
  if (!darks.ok()) return darks.status();
  CaptureResult result;
  result.out = out;
  for (size_t k = 0; k < leds.size(); ++k) {
    if (done.count(int(k))) {
      result.resumed++;
      continue;
    }
    MATFIT_RETURN_IF_ERROR(rig.AllOff());
    MATFIT_RETURN_IF_ERROR(rig.Set(leds[k], plan.level));
    int64_t sat = 0;
    auto img = Bracketed(cam, plan, *darks, &sat);
    if (!img.ok()) {
      (void)rig.AllOff();
      return Status(img.status().code(), img.status().message() + " (at image " +
                                             std::to_string(k) +
                                             "; run the same command again "
                                             "to resume)");
    }
    if (!flat.empty()) ApplyFlatField(flat, &*img);
    // The .lp readers take intensities as nominal: divide out the LED level.
    for (float& v : img->data()) v = float(v / plan.level);
    MATFIT_RETURN_IF_ERROR(WriteImage((dir / Name(int(k))).string(), *img, Exr()));
    const Vec3 d = rig.Direction(leds[k]);
    record["images"].push_back(
        {{"index", k},
         {"file", Name(int(k))},
         {"led", leds[k]},
         {"direction", {d.x, d.y, d.z}},
         {"saturated_pixels", sat},
         {"unix_time",
          std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
              .count()}});
    MATFIT_RETURN_IF_ERROR(save());
    result.images++;
    result.saturated_pixels += sat;
    if (progress && !progress(int(k + 1), int(leds.size()))) {
      (void)rig.AllOff();
      return Status(StatusCode::kCancelled, "capture stopped after image " + std::to_string(k) +
                                                "; run the same command again to resume");
    }
  }
  MATFIT_RETURN_IF_ERROR(rig.AllOff());
  // The light file last: a dataset is readable only when complete.
  std::string lp = std::to_string(leds.size()) + "\n";
  for (size_t k = 0; k < leds.size(); ++k) {
    const Vec3 d = rig.Direction(leds[k]);
    char line[160];
    std::snprintf(line, sizeof line, "%s %.9f %.9f %.9f\n", Name(int(k)).c_str(), d.x, d.y, d.z);
    lp += line;
  }
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic((dir / "lights.lp").string(), lp));
  MaterialMaps truth;
  if (SimCameraTruth(cam, !flat.empty(), &truth)) {  // simulated: ground truth for scoring
    const fs::path t = dir / "truth";
    fs::create_directories(t, ec);
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "normal.exr").string(), truth.normal, Exr()));
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "albedo.exr").string(), truth.albedo, Exr()));
    ImageWriteOptions png;
    png.format = ::matfit::PixelFormat::kUint8;
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "mask.png").string(), truth.mask, png));
    const json params = {{"schema", "matfit.truth/1"},
                         {"source", "matfit capture with " + camera_uri},
                         {"model", {{"name", ShadingModelName(truth.model)}}},
                         {"note",
                          "albedo in the capture's units (sensor sensitivity, vignetting "
                          "or its mean when flat-fielded)"}};
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((t / "params.json").string(), params.dump(2) + "\n"));
  }
  record["complete"] = true;
  MATFIT_RETURN_IF_ERROR(save());
  return result;
}

Status CaptureFlatField(Camera& cam, LightRig& rig, const CapturePlan& plan,
                        const std::string& out) {
  std::string why;
  if (!plan.Check(&why)) return InvalidArgument(why);
  MATFIT_RETURN_IF_ERROR(Setup(cam, rig, plan));
  auto darks = Darks(cam, rig, plan);
  if (!darks.ok()) return darks.status();
  MATFIT_RETURN_IF_ERROR(rig.All(plan.level));
  int64_t sat = 0;
  auto img = Bracketed(cam, plan, *darks, &sat);
  (void)rig.AllOff();
  if (!img.ok()) return img.status();
  if (sat > img->plane_size() / 100)
    return DataError("the flat-field target saturates at every exposure in " + std::to_string(sat) +
                     " pixels; add a shorter exposure");
  return WriteImage(out, NormaliseFlat(*img), Exr());
}

}  // namespace matfit::capture
